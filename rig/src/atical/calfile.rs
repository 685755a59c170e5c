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
pub(crate) const AXES: [&str; 6] = ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"];

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
        let reader = CalReader { source };
        let doc = roxmltree::Document::parse(text)
            .map_err(|e| reader.invalid("XML", format!("not valid XML: {e}")))?;
        let root = doc.root_element();
        reader.check_root(root)?;
        let cal = root
            .children()
            .find(|n| is_element_named(n, "Calibration"))
            .ok_or_else(|| reader.invalid("<Calibration>", "element is missing".into()))?;
        let units = reader.units(cal)?;
        let has_user_axes = cal.children().any(|n| is_element_named(&n, "UserAxis"));
        let row_tag = if has_user_axes { "UserAxis" } else { "Axis" };
        let rows = reader.axis_rows(cal, row_tag)?;
        let (mut matrix, max_loads) = reader.assemble(&rows, row_tag, &units)?;
        if !has_user_axes {
            if let Some(bt) = cal
                .children()
                .find(|n| is_element_named(n, "BasicTransform"))
            {
                matrix = reader.basic_transform(bt, &units)?.matrix() * matrix;
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
            force_units: units.force,
            torque_units: units.torque,
            dist_units: units.dist,
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

/// One axis row as read: the six matrix values divided by `scale`, and the rated load `max`,
/// both still in the file's units.
type AxisRow = ([f64; 6], f64);

/// The `<Calibration>` element's units and their factors to N, N m, m and rad.
struct Units {
    force: String,
    torque: String,
    dist: String,
    /// N per force unit.
    force_factor: f64,
    /// N m per torque unit.
    torque_factor: f64,
    /// m per distance unit.
    dist_factor: f64,
    /// rad per angle unit.
    angle_factor: f64,
}

/// Whether `node` is an element with tag `name`.
fn is_element_named(node: &roxmltree::Node<'_, '_>, name: &str) -> bool {
    node.is_element() && node.tag_name().name() == name
}

/// The trimmed value of attribute `name`, empty when it is absent.
fn attr(node: roxmltree::Node<'_, '_>, name: &str) -> String {
    node.attribute(name).unwrap_or("").trim().to_string()
}

/// Reads the parts of one `.cal` document, naming `source` in its errors.
struct CalReader<'s> {
    source: &'s str,
}

impl CalReader<'_> {
    /// A [`CalError::Invalid`] for `element` of this file.
    fn invalid(&self, element: &str, message: String) -> CalError {
        CalError::Invalid {
            file: self.source.to_string(),
            element: element.to_string(),
            message,
        }
    }

    /// The trimmed, non-empty value of attribute `name` of `node`, called `element` in errors.
    fn required(
        &self,
        node: roxmltree::Node<'_, '_>,
        element: &str,
        name: &str,
    ) -> Result<String, CalError> {
        match node.attribute(name).map(str::trim) {
            Some(v) if !v.is_empty() => Ok(v.to_string()),
            _ => Err(self.invalid(element, format!("attribute `{name}` is missing"))),
        }
    }

    /// Checks that the root is `<FTSensor>` for a six-gauge transducer.
    fn check_root(&self, root: roxmltree::Node<'_, '_>) -> Result<(), CalError> {
        if root.tag_name().name() != "FTSensor" {
            return Err(self.invalid(
                &format!("<{}>", root.tag_name().name()),
                "the root element must be <FTSensor>".into(),
            ));
        }
        let num_gages = attr(root, "NumGages");
        if !num_gages.is_empty() && num_gages != "6" {
            return Err(self.invalid(
                "<FTSensor>",
                format!("NumGages is {num_gages}; only six-gauge transducers are supported"),
            ));
        }
        Ok(())
    }

    /// The units named by `<Calibration>` and their conversion factors.
    fn units(&self, cal: roxmltree::Node<'_, '_>) -> Result<Units, CalError> {
        let force = self.required(cal, "<Calibration>", "ForceUnits")?;
        let torque = self.required(cal, "<Calibration>", "TorqueUnits")?;
        let dist = self.required(cal, "<Calibration>", "DistUnits")?;
        let angle = cal
            .attribute("AngleUnits")
            .unwrap_or("degrees")
            .trim()
            .to_string();
        let unknown = |what: &str, unit: &str, known: &str| {
            self.invalid(
                "<Calibration>",
                format!("{what} `{unit}` is unknown (known: {known})"),
            )
        };
        let force_factor =
            newtons_per(&force).ok_or_else(|| unknown("ForceUnits", &force, FORCE_UNITS))?;
        let torque_factor = newton_metres_per(&torque)
            .ok_or_else(|| unknown("TorqueUnits", &torque, TORQUE_UNITS))?;
        let dist_factor =
            metres_per(&dist).ok_or_else(|| unknown("DistUnits", &dist, LENGTH_UNITS))?;
        let angle_factor = match angle.to_ascii_lowercase().as_str() {
            "deg" | "degree" | "degrees" => std::f64::consts::PI / 180.0,
            "rad" | "radian" | "radians" => 1.0,
            other => return Err(unknown("AngleUnits", other, "degrees, radians")),
        };
        Ok(Units {
            force,
            torque,
            dist,
            force_factor,
            torque_factor,
            dist_factor,
            angle_factor,
        })
    }

    /// The six `row_tag` rows of `<Calibration>` by axis, `None` for an axis not given.
    fn axis_rows(
        &self,
        cal: roxmltree::Node<'_, '_>,
        row_tag: &str,
    ) -> Result<[Option<AxisRow>; 6], CalError> {
        let mut rows: [Option<AxisRow>; 6] = [None; 6];
        for node in cal.children().filter(|n| is_element_named(n, row_tag)) {
            let name = attr(node, "Name");
            let element = format!("<{row_tag} Name=\"{name}\">");
            let idx = AXES.iter().position(|a| *a == name).ok_or_else(|| {
                self.invalid(&element, format!("Name must be one of {}", AXES.join(", ")))
            })?;
            if rows[idx].is_some() {
                return Err(self.invalid(&element, "this axis appears twice".into()));
            }
            rows[idx] = Some(self.axis_row(node, &element, row_tag)?);
        }
        Ok(rows)
    }

    /// One axis row's `values / scale` and `max`; `scale` may be left out of a `UserAxis` only.
    fn axis_row(
        &self,
        node: roxmltree::Node<'_, '_>,
        element: &str,
        row_tag: &str,
    ) -> Result<AxisRow, CalError> {
        let values_text = self.required(node, element, "values")?;
        let values: Vec<f64> = values_text
            .split_whitespace()
            .map(|v| {
                v.parse::<f64>()
                    .map_err(|_| self.invalid(element, format!("values: `{v}` is not a number")))
            })
            .collect::<Result<_, _>>()?;
        let values: [f64; 6] = values.try_into().map_err(|v: Vec<f64>| {
            self.invalid(
                element,
                format!("values has {} numbers, expected 6 (one per gauge)", v.len()),
            )
        })?;
        let scale_text = node.attribute("scale").map(str::trim).unwrap_or("");
        let scale = if scale_text.is_empty() {
            if row_tag == "Axis" {
                return Err(self.invalid(element, "attribute `scale` is missing".into()));
            }
            1.0
        } else {
            scale_text
                .parse::<f64>()
                .ok()
                .filter(|s| s.is_finite() && *s != 0.0)
                .ok_or_else(|| {
                    self.invalid(
                        element,
                        format!("scale `{scale_text}` must be a non-zero number"),
                    )
                })?
        };
        let max_text = node.attribute("max").map(str::trim).unwrap_or("0");
        let max = max_text
            .parse::<f64>()
            .map_err(|_| self.invalid(element, format!("max `{max_text}` is not a number")))?;
        let row = values.map(|v| v / scale);
        if row.iter().any(|v| !v.is_finite()) {
            return Err(self.invalid(element, "values must be finite numbers".into()));
        }
        Ok((row, max))
    }

    /// The matrix in N and N m per volt and the rated loads, from all six rows.
    fn assemble(
        &self,
        rows: &[Option<AxisRow>; 6],
        row_tag: &str,
        units: &Units,
    ) -> Result<(Matrix6<f64>, [f64; 6]), CalError> {
        let mut matrix = Matrix6::zeros();
        let mut max_loads = [0.0; 6];
        for (i, row) in rows.iter().enumerate() {
            let (values, max) = row.ok_or_else(|| {
                self.invalid(
                    &format!("<{row_tag} Name=\"{}\">", AXES[i]),
                    "element is missing".into(),
                )
            })?;
            let conv = if i < 3 {
                units.force_factor
            } else {
                units.torque_factor
            };
            for (j, v) in values.iter().enumerate() {
                matrix[(i, j)] = v * conv;
            }
            max_loads[i] = max * conv;
        }
        Ok((matrix, max_loads))
    }

    /// The `<BasicTransform>` (a missing attribute is 0) in metres and radians.
    fn basic_transform(
        &self,
        bt: roxmltree::Node<'_, '_>,
        units: &Units,
    ) -> Result<ToolTransform, CalError> {
        let mut tt = [0.0; 6];
        for (k, name) in ["Dx", "Dy", "Dz", "Rx", "Ry", "Rz"].iter().enumerate() {
            let text = bt.attribute(*name).map(str::trim).unwrap_or("0");
            tt[k] = text
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    self.invalid(
                        "<BasicTransform>",
                        format!("{name} `{text}` is not a number"),
                    )
                })?;
        }
        let d = units.dist_factor;
        let a = units.angle_factor;
        Ok(ToolTransform::from_ati(
            [tt[0] * d, tt[1] * d, tt[2] * d],
            [tt[3] * a, tt[4] * a, tt[5] * a],
        ))
    }
}
