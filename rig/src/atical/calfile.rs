//! ATI `.cal` calibration files (XML).
//!
//! ```text
//! <FTSensor Serial=".." BodyStyle=".." Family="DAQ" NumGages="6" CalFileVersion="1.0|1.1">
//!   <Calibration PartNumber=".." CalDate=".." ForceUnits="N" TorqueUnits="N-m" DistUnits="m"
//!                [AngleUnits="degrees"] ...>
//!     <Axis Name="Fx" values="g0 .. g5" max=".." scale=".."/>   (six, Fx..Tz)
//!     <BasicTransform Dx Dy Dz Rx Ry Rz/>
//!     <UserAxis Name="Fx" values=".." max=".." [scale=".."]/>   (version 1.1, six)
//!   </Calibration>
//! </FTSensor>
//! ```
//!
//! Matrix row i is `values / scale`. Version 1.0 `Axis` rows are in the basic frame and the
//! `BasicTransform` is applied to them; version 1.1 `UserAxis` rows already include it, so when
//! they are present they are used as they are and the transform is never applied a second time.
//! The resulting matrix maps gauge volts to N and N m whatever units the file uses.

use super::transform::ToolTransform;
use crate::ft_units::{
    metres_per, newton_metres_per, newtons_per, FORCE_UNITS, LENGTH_UNITS, TORQUE_UNITS,
};
use nalgebra::{Matrix6, Vector6};
use std::path::{Path, PathBuf};

/// Axis names in matrix order.
pub const AXES: [&str; 6] = ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"];

/// A `.cal` file that cannot be used, naming the file and the element.
#[derive(Debug, thiserror::Error)]
pub enum CalError {
    #[error("cannot read calibration file {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("calibration file {file}: {element}: {message}")]
    Invalid {
        file: String,
        element: String,
        message: String,
    },
}

/// A parsed calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// Where it came from (file path or a name).
    pub source: String,
    pub serial: String,
    pub body_style: String,
    pub family: String,
    pub part_number: String,
    pub cal_date: String,
    pub file_version: String,
    /// Units used in the file (the matrix here is already converted to N and N m).
    pub force_units: String,
    pub torque_units: String,
    pub dist_units: String,
    /// Whether `UserAxis` rows (version 1.1) were used.
    pub user_axes: bool,
    /// Rated load per axis in N (forces) and N m (torques).
    pub max_loads: [f64; 6],
    /// Gauge volts -> `[Fx Fy Fz Tx Ty Tz]` in N and N m, in the user frame.
    pub matrix: Matrix6<f64>,
}

impl Calibration {
    /// Loads and parses a `.cal` file.
    pub fn load(path: &Path) -> Result<Calibration, CalError> {
        let text = std::fs::read_to_string(path).map_err(|source| CalError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Calibration::parse(&text, &path.display().to_string())
    }

    /// Parses `.cal` text; `source` names it in errors.
    pub fn parse(text: &str, source: &str) -> Result<Calibration, CalError> {
        let invalid = |element: &str, message: String| CalError::Invalid {
            file: source.to_string(),
            element: element.to_string(),
            message,
        };
        let doc = roxmltree::Document::parse(text)
            .map_err(|e| invalid("XML", format!("not valid XML: {e}")))?;
        let root = doc.root_element();
        if root.tag_name().name() != "FTSensor" {
            return Err(invalid(
                &format!("<{}>", root.tag_name().name()),
                "the root element must be <FTSensor>".into(),
            ));
        }
        let attr = |node: roxmltree::Node, name: &str| {
            node.attribute(name).unwrap_or("").trim().to_string()
        };
        let required =
            |node: roxmltree::Node, element: &str, name: &str| -> Result<String, CalError> {
                match node.attribute(name).map(str::trim) {
                    Some(v) if !v.is_empty() => Ok(v.to_string()),
                    _ => Err(invalid(element, format!("attribute `{name}` is missing"))),
                }
            };
        let num_gages = attr(root, "NumGages");
        if !num_gages.is_empty() && num_gages != "6" {
            return Err(invalid(
                "<FTSensor>",
                format!("NumGages is {num_gages}; only six-gauge transducers are supported"),
            ));
        }
        let cal = root
            .children()
            .find(|n| n.is_element() && n.tag_name().name() == "Calibration")
            .ok_or_else(|| invalid("<Calibration>", "element is missing".into()))?;
        let force_units = required(cal, "<Calibration>", "ForceUnits")?;
        let torque_units = required(cal, "<Calibration>", "TorqueUnits")?;
        let dist_units = required(cal, "<Calibration>", "DistUnits")?;
        let angle_units = cal
            .attribute("AngleUnits")
            .unwrap_or("degrees")
            .trim()
            .to_string();
        let f_conv = newtons_per(&force_units).ok_or_else(|| {
            invalid(
                "<Calibration>",
                format!("ForceUnits `{force_units}` is unknown (known: {FORCE_UNITS})"),
            )
        })?;
        let t_conv = newton_metres_per(&torque_units).ok_or_else(|| {
            invalid(
                "<Calibration>",
                format!("TorqueUnits `{torque_units}` is unknown (known: {TORQUE_UNITS})"),
            )
        })?;
        let d_conv = metres_per(&dist_units).ok_or_else(|| {
            invalid(
                "<Calibration>",
                format!("DistUnits `{dist_units}` is unknown (known: {LENGTH_UNITS})"),
            )
        })?;
        let a_conv = match angle_units.to_ascii_lowercase().as_str() {
            "deg" | "degree" | "degrees" => std::f64::consts::PI / 180.0,
            "rad" | "radian" | "radians" => 1.0,
            other => {
                return Err(invalid(
                    "<Calibration>",
                    format!("AngleUnits `{other}` is unknown (known: degrees, radians)"),
                ))
            }
        };

        let has_user_axes = cal
            .children()
            .any(|n| n.is_element() && n.tag_name().name() == "UserAxis");
        let row_tag = if has_user_axes { "UserAxis" } else { "Axis" };
        let mut rows: [Option<([f64; 6], f64)>; 6] = [None; 6];
        for node in cal
            .children()
            .filter(|n| n.is_element() && n.tag_name().name() == row_tag)
        {
            let name = attr(node, "Name");
            let element = format!("<{row_tag} Name=\"{name}\">");
            let idx = AXES.iter().position(|a| *a == name).ok_or_else(|| {
                invalid(&element, format!("Name must be one of {}", AXES.join(", ")))
            })?;
            if rows[idx].is_some() {
                return Err(invalid(&element, "this axis appears twice".into()));
            }
            let values_text = required(node, &element, "values")?;
            let values: Vec<f64> = values_text
                .split_whitespace()
                .map(|v| {
                    v.parse::<f64>()
                        .map_err(|_| invalid(&element, format!("values: `{v}` is not a number")))
                })
                .collect::<Result<_, _>>()?;
            let values: [f64; 6] = values.try_into().map_err(|v: Vec<f64>| {
                invalid(
                    &element,
                    format!("values has {} numbers, expected 6 (one per gauge)", v.len()),
                )
            })?;
            let scale_text = node.attribute("scale").map(str::trim).unwrap_or("");
            let scale = if scale_text.is_empty() {
                if row_tag == "Axis" {
                    return Err(invalid(&element, "attribute `scale` is missing".into()));
                }
                1.0
            } else {
                scale_text
                    .parse::<f64>()
                    .ok()
                    .filter(|s| s.is_finite() && *s != 0.0)
                    .ok_or_else(|| {
                        invalid(
                            &element,
                            format!("scale `{scale_text}` must be a non-zero number"),
                        )
                    })?
            };
            let max_text = node.attribute("max").map(str::trim).unwrap_or("0");
            let max = max_text
                .parse::<f64>()
                .map_err(|_| invalid(&element, format!("max `{max_text}` is not a number")))?;
            let row = values.map(|v| v / scale);
            if row.iter().any(|v| !v.is_finite()) {
                return Err(invalid(&element, "values must be finite numbers".into()));
            }
            rows[idx] = Some((row, max));
        }
        let mut matrix = Matrix6::zeros();
        let mut max_loads = [0.0; 6];
        for (i, row) in rows.iter().enumerate() {
            let (values, max) = row.ok_or_else(|| {
                invalid(
                    &format!("<{row_tag} Name=\"{}\">", AXES[i]),
                    "element is missing".into(),
                )
            })?;
            let conv = if i < 3 { f_conv } else { t_conv };
            for (j, v) in values.iter().enumerate() {
                matrix[(i, j)] = v * conv;
            }
            max_loads[i] = max * conv;
        }
        if !has_user_axes {
            if let Some(bt) = cal
                .children()
                .find(|n| n.is_element() && n.tag_name().name() == "BasicTransform")
            {
                let mut tt = [0.0; 6];
                for (k, name) in ["Dx", "Dy", "Dz", "Rx", "Ry", "Rz"].iter().enumerate() {
                    let text = bt.attribute(*name).map(str::trim).unwrap_or("0");
                    tt[k] = text
                        .parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| {
                            invalid(
                                "<BasicTransform>",
                                format!("{name} `{text}` is not a number"),
                            )
                        })?;
                }
                let basic = ToolTransform::from_ati(
                    [tt[0] * d_conv, tt[1] * d_conv, tt[2] * d_conv],
                    [tt[3] * a_conv, tt[4] * a_conv, tt[5] * a_conv],
                );
                matrix = basic.matrix() * matrix;
            }
        }
        Ok(Calibration {
            source: source.to_string(),
            serial: attr(root, "Serial"),
            body_style: attr(root, "BodyStyle"),
            family: attr(root, "Family"),
            part_number: attr(cal, "PartNumber"),
            cal_date: attr(cal, "CalDate"),
            file_version: attr(root, "CalFileVersion"),
            force_units,
            torque_units,
            dist_units,
            user_axes: has_user_axes,
            max_loads,
            matrix,
        })
    }

    /// `[Fx Fy Fz Tx Ty Tz]` in N and N m for six gauge voltages, after subtracting `bias` and
    /// applying the optional tool transform.
    pub fn convert(
        &self,
        volts: [f64; 6],
        bias: [f64; 6],
        tool: Option<&ToolTransform>,
    ) -> [f64; 6] {
        let v = Vector6::from_fn(|i, _| volts[i] - bias[i]);
        let w = self.matrix * v;
        let w: [f64; 6] = std::array::from_fn(|i| w[i]);
        match tool {
            Some(t) => t.apply(w),
            None => w,
        }
    }
}
