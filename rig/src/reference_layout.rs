//! The reference pipeline's dataset layout, owned here: `0.images/` holds one image per frame and
//! `0.labels.csv` one row per image, with exactly the columns the paper's Python training code
//! reads, written and read with the `csv` crate. The run export (`store::export`), the
//! simulator's datasets, the models' dataset reader and the calibration's choice of no-contact
//! frames all go through this module; the no-contact rule (|Fz| under 0.2 N, shape `None`) is
//! defined here and nowhere else.
//!
//! Columns: New_Image_Name, Fx, Fy, Fz, Mx, My, Mz, Ft, X_Position_mm, Y_Position_mm,
//! Indentor_Shape. Forces in N, torques in N m (the reference mixed N m and N mm: fringe writes
//! N m everywhere), Ft = |F| = sqrt(Fx^2 + Fy^2 + Fz^2), positions = the contact point in mm from
//! the sensor centre, `NaN` and shape `None` without contact. Values are written in full
//! precision ([`LabelWriter::new`] without a step, the simulator's exact labels), rounded to a
//! step asked for, or at the precision of the measurement ([`LabelWriter::measured`], what run
//! exports write: [`MEASURED_DECIMALS`]); negative zero is written as 0.

use crate::units::Newtons;
use std::io::Write;
use std::path::{Component, Path, PathBuf};

/// File name of the labels.
pub const LABELS: &str = "0.labels.csv";
/// Directory of the images.
pub const IMAGES: &str = "0.images";
/// Beside them in a dataset `fringe sim dataset` rendered: its spec (count, seed, the simulated
/// sensor with its `variant`), and the sensor's design geometry as a calibration profile.
pub const SIM_DATASET_DOC: &str = "dataset.json";
pub const SIM_DATASET_PROFILE: &str = "profile.toml";
/// The columns, in the reference's order.
pub const COLUMNS: [&str; 11] = [
    "New_Image_Name",
    "Fx",
    "Fy",
    "Fz",
    "Mx",
    "My",
    "Mz",
    "Ft",
    "X_Position_mm",
    "Y_Position_mm",
    "Indentor_Shape",
];
/// The shape class of a frame without contact.
pub const NO_CONTACT: &str = "None";
/// Below this |Fz| a frame has no contact: shape `None`, no contact point (the paper's rule; the
/// F/T sensor's noise floor).
pub const CONTACT_THRESHOLD: Newtons = Newtons(0.2);
/// The largest force or moment a label row may hold, N or N m: far beyond any F/T sensor of an
/// indentation bench (a row beyond it is a unit or parsing mistake, not a reading).
pub const MAX_LABEL: f64 = 1e4;

/// Whether a normal force `fz` is a contact.
pub fn in_contact(fz: Newtons) -> bool {
    fz.0.abs() >= CONTACT_THRESHOLD.0
}

/// A row's shape: no contact, or the indenter's name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Shape {
    NoContact,
    Indenter(String),
}

impl Shape {
    /// The shape a label names (`None`: no contact).
    pub fn parse(name: &str) -> Shape {
        if name == NO_CONTACT {
            Shape::NoContact
        } else {
            Shape::Indenter(name.to_string())
        }
    }

    /// The name in the labels file.
    pub fn as_str(&self) -> &str {
        match self {
            Shape::NoContact => NO_CONTACT,
            Shape::Indenter(name) => name,
        }
    }
}

/// One row of `0.labels.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelRow {
    /// File name inside `0.images/`.
    pub image: String,
    /// Fx Fy Fz (N), Mx My Mz (N m), signed as measured.
    pub wrench: [f64; 6],
    /// Contact point, mm from the sensor centre; `None` without contact.
    pub contact: Option<[f64; 2]>,
    pub shape: Shape,
}

impl LabelRow {
    /// Ft = |F|, N.
    pub fn ft(&self) -> f64 {
        let [fx, fy, fz, ..] = self.wrench;
        (fx * fx + fy * fy + fz * fz).sqrt()
    }
}

/// Decimals of the labels a run export writes, column by column after the image name (Fx, Fy,
/// Fz, Mx, My, Mz, Ft, X, Y): forces in N to 1 mN and torques in N m to 10 uN m, ten times finer
/// than the resolution of the reference F/T transducer (ATI Mini40 SI-40-2: 1/100 N in Fx and
/// Fy, 1/50 N in Fz, 1/4000 N m) and of the simulated one, so averaging over an exposure loses
/// nothing; contact positions in mm to 1 um, finer than the stages' repeatability. The float
/// noise of a sum of samples (`1.9999998474121092`) is below them all.
pub const MEASURED_DECIMALS: [usize; 9] = [3, 3, 3, 5, 5, 5, 3, 3, 3];

/// How the values of a labels file are written.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Precision {
    /// As computed (shortest text that reads back the same number), or rounded to a step.
    Step(Option<f64>),
    /// [`MEASURED_DECIMALS`].
    Measured,
}

/// Writes `0.labels.csv` rows, the header first.
pub struct LabelWriter<W: Write> {
    csv: csv::Writer<W>,
    precision: Precision,
}

impl<W: Write> LabelWriter<W> {
    /// A writer into `out`, rounding values to `round` when given (the reference trained on 0.1),
    /// else writing them in full.
    pub fn new(out: W, round: Option<f64>) -> std::io::Result<LabelWriter<W>> {
        Self::with(out, Precision::Step(round))
    }

    /// A writer into `out` at the precision of the measurement ([`MEASURED_DECIMALS`]).
    pub fn measured(out: W) -> std::io::Result<LabelWriter<W>> {
        Self::with(out, Precision::Measured)
    }

    fn with(out: W, precision: Precision) -> std::io::Result<LabelWriter<W>> {
        let mut csv = csv::WriterBuilder::new().from_writer(out);
        csv.write_record(COLUMNS).map_err(into_io)?;
        Ok(LabelWriter { csv, precision })
    }

    pub fn write(&mut self, row: &LabelRow) -> std::io::Result<()> {
        let [x, y] = row.contact.unwrap_or([f64::NAN, f64::NAN]);
        let values = row.wrench.into_iter().chain([row.ft(), x, y]);
        let mut fields = Vec::with_capacity(COLUMNS.len());
        fields.push(row.image.clone());
        match self.precision {
            Precision::Step(round) => fields.extend(values.map(|v| format_value(v, round))),
            Precision::Measured => fields.extend(
                values
                    .zip(MEASURED_DECIMALS)
                    .map(|(v, decimals)| format_decimals(v, decimals)),
            ),
        }
        fields.push(row.shape.as_str().to_string());
        self.csv.write_record(&fields).map_err(into_io)
    }

    /// Flushes and returns the underlying writer.
    pub fn finish(self) -> std::io::Result<W> {
        self.csv
            .into_inner()
            .map_err(|e| std::io::Error::other(e.to_string()))
    }
}

fn into_io(e: csv::Error) -> std::io::Error {
    match e.into_kind() {
        csv::ErrorKind::Io(io) => io,
        other => std::io::Error::other(format!("{other:?}")),
    }
}

/// A value as the labels file holds it: `NaN`, full precision, or rounded to `round`.
pub fn format_value(v: f64, round: Option<f64>) -> String {
    if v.is_nan() {
        return "NaN".into();
    }
    // Negative zero is written as 0.
    let v = if v == 0.0 { 0.0 } else { v };
    match round {
        Some(step) if step > 0.0 => {
            let r = (v / step).round() * step;
            let r = if r == 0.0 { 0.0 } else { r };
            let decimals = (-step.log10()).ceil().max(0.0) as usize;
            format!("{r:.decimals$}")
        }
        _ => format!("{v}"),
    }
}

/// A value to `decimals` places without trailing zeros (`2`, `-0.034`, `NaN`); negative zero,
/// and a value that rounds to zero, written as 0.
pub fn format_decimals(v: f64, decimals: usize) -> String {
    if v.is_nan() {
        return "NaN".into();
    }
    let text = format!("{v:.decimals$}");
    let text = if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.')
    } else {
        &text
    };
    match text {
        "-0" => "0".into(),
        t => t.to_string(),
    }
}

/// What is wrong with a labels file: the file, the line (1 is the header; 0: the file itself)
/// and what.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}: line {line}: {message}", path.display())]
pub struct LabelsError {
    pub path: PathBuf,
    pub line: u64,
    pub message: String,
}

/// The rows of the labels file at `path`, each with its line, checked: every force and moment a
/// finite number within [`MAX_LABEL`], an image name inside `0.images/`, and a contact position
/// on every row that presses an indenter with |Fz| at or above the threshold. Columns are found by
/// name (Ft is not needed: it follows from the forces).
pub fn read_labels(path: &Path) -> Result<Vec<(u64, LabelRow)>, LabelsError> {
    let err = |line: u64, message: String| LabelsError {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut reader = csv::Reader::from_path(path).map_err(|e| err(0, e.to_string()))?;
    let headers = reader.headers().map_err(|e| err(1, e.to_string()))?.clone();
    let columns = LabelColumns::find(&headers).map_err(|m| err(1, m))?;
    let mut rows = Vec::new();
    for (k, record) in reader.records().enumerate() {
        let line = k as u64 + 2;
        let record = record.map_err(|e| err(line, e.to_string()))?;
        let row = columns.row(&record).map_err(|m| err(line, m))?;
        rows.push((line, row));
    }
    Ok(rows)
}

/// Where a labels file has the columns it is read by: every column but Ft, in [`COLUMNS`]
/// order.
struct LabelColumns {
    /// The columns' names.
    names: Vec<&'static str>,
    /// Each column's position in the file.
    at: Vec<usize>,
}

impl LabelColumns {
    /// Finds every column but Ft by name among `headers`.
    fn find(headers: &csv::StringRecord) -> Result<LabelColumns, String> {
        let names: Vec<&'static str> = COLUMNS.iter().copied().filter(|c| *c != "Ft").collect();
        let mut at = Vec::with_capacity(names.len());
        for name in &names {
            let position = headers
                .iter()
                .position(|h| h.trim() == *name)
                .ok_or_else(|| {
                    format!(
                        "no column {name} (the reference layout has New_Image_Name, Fx .. Ft, \
                     X_Position_mm, Y_Position_mm, Indentor_Shape)"
                    )
                })?;
            at.push(position);
        }
        Ok(LabelColumns { names, at })
    }

    /// Field `i` of `record`, trimmed; empty when the row is short.
    fn field<'r>(&self, record: &'r csv::StringRecord, i: usize) -> &'r str {
        record.get(self.at[i]).unwrap_or("").trim()
    }

    /// Field `i` of `record` as a number; NaN when it is empty or `nan`.
    fn num(&self, record: &csv::StringRecord, i: usize) -> Result<f64, String> {
        let text = self.field(record, i);
        if text.is_empty() || text.eq_ignore_ascii_case("nan") {
            return Ok(f64::NAN);
        }
        text.parse::<f64>()
            .map_err(|_| format!("{} = {text:?} is not a number", self.names[i]))
    }

    /// One row, checked: wrench, contact position where the indenter presses, image name.
    fn row(&self, record: &csv::StringRecord) -> Result<LabelRow, String> {
        let wrench = self.wrench(record)?;
        let (x, y) = (self.num(record, 7)?, self.num(record, 8)?);
        let contact = (x.is_finite() && y.is_finite()).then_some([x, y]);
        let shape = Shape::parse(self.field(record, 9));
        if contact.is_none() && shape != Shape::NoContact && in_contact(Newtons(wrench[2])) {
            return Err(format!(
                "Fz = {} N presses a {} but the row has no contact position \
                 (X_Position_mm, Y_Position_mm): give it, or mark the row Indentor_Shape None",
                wrench[2],
                shape.as_str()
            ));
        }
        let image = self.field(record, 0);
        check_image_name(image)?;
        Ok(LabelRow {
            image: image.to_string(),
            wrench,
            contact,
            shape,
        })
    }

    /// The row's forces and moments, each a finite number within [`MAX_LABEL`].
    fn wrench(&self, record: &csv::StringRecord) -> Result<[f64; 6], String> {
        let wrench = [
            self.num(record, 1)?,
            self.num(record, 2)?,
            self.num(record, 3)?,
            self.num(record, 4)?,
            self.num(record, 5)?,
            self.num(record, 6)?,
        ];
        if wrench.iter().any(|v| !v.is_finite()) {
            return Err("a force or moment is missing".into());
        }
        if let Some((i, v)) = wrench.iter().enumerate().find(|(_, v)| v.abs() > MAX_LABEL) {
            return Err(format!(
                "{} = {v:e} is beyond {MAX_LABEL:e} (N or N m): not a reading of a force \
                 sensor; fix or remove the row",
                self.names[i + 1]
            ));
        }
        Ok(wrench)
    }
}

/// Checks that an image name is a plain relative path, inside the dataset's images.
fn check_image_name(image: &str) -> Result<(), String> {
    let plain = !image.is_empty()
        && Path::new(image)
            .components()
            .all(|c| matches!(c, Component::Normal(_)));
    if !plain {
        return Err(format!(
            "New_Image_Name = {image:?} is not a file name inside {IMAGES}/ (no absolute \
             path, no `..`): a dataset holds its own images"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(image: &str, fz: f64, contact: Option<[f64; 2]>, shape: &str) -> LabelRow {
        LabelRow {
            image: image.into(),
            wrench: [0.25, -0.0, fz, 0.001, -0.002, 0.0],
            contact,
            shape: Shape::parse(shape),
        }
    }

    #[test]
    fn rows_written_are_read_back_with_the_reference_columns() {
        let dir = std::env::temp_dir().join(format!("fringe-labels-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join(LABELS);
        let rows = [
            row("image_0.png", -3.5, Some([1.25, -2.0]), "pentagon"),
            row("image_1.png", -0.05, None, NO_CONTACT),
        ];
        let mut w = LabelWriter::new(Vec::new(), None).expect("writer");
        for r in &rows {
            w.write(r).expect("row");
        }
        let bytes = w.finish().expect("finish");
        let text = String::from_utf8(bytes.clone()).expect("utf-8");
        assert_eq!(
            text,
            "New_Image_Name,Fx,Fy,Fz,Mx,My,Mz,Ft,X_Position_mm,Y_Position_mm,Indentor_Shape\n\
             image_0.png,0.25,0,-3.5,0.001,-0.002,0,3.5089172119045497,1.25,-2,pentagon\n\
             image_1.png,0.25,0,-0.05,0.001,-0.002,0,0.25495097567963926,NaN,NaN,None\n"
        );
        std::fs::write(&path, &bytes).expect("write");
        let back: Vec<LabelRow> = read_labels(&path)
            .expect("read")
            .into_iter()
            .map(|(_, r)| r)
            .collect();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(back[0], rows[0]);
        assert_eq!(back[1].shape, Shape::NoContact);
        assert_eq!(back[1].contact, None);
        assert!(in_contact(Newtons(back[0].wrench[2])) && !in_contact(Newtons(back[1].wrench[2])));
    }

    #[test]
    fn measured_labels_carry_no_float_noise() {
        assert_eq!(format_decimals(1.999_999_847_412_109_2, 3), "2");
        assert_eq!(format_decimals(-0.000_4, 3), "0");
        assert_eq!(format_decimals(-0.034_04, 3), "-0.034");
        assert_eq!(format_decimals(f64::NAN, 3), "NaN");
        assert_eq!(format_decimals(12.0, 5), "12");
        let mut w = LabelWriter::measured(Vec::new()).expect("writer");
        let noisy = LabelRow {
            image: "image_0.tiff".into(),
            wrench: [
                0.300_000_01,
                -0.0,
                -1.999_999_847_412_109_2,
                0.012_345_6,
                0.0,
                -0.0,
            ],
            contact: Some([1.250_000_4, -2.0]),
            shape: Shape::parse("pentagon"),
        };
        w.write(&noisy).expect("row");
        let text = String::from_utf8(w.finish().expect("finish")).expect("utf-8");
        assert_eq!(
            text.lines().nth(1),
            Some("image_0.tiff,0.3,0,-2,0.01235,0,0,2.022,1.25,-2,pentagon")
        );
    }

    #[test]
    fn rounding_and_bad_rows_name_the_line_and_column() {
        assert_eq!(format_value(-0.04, Some(0.1)), "0.0");
        assert_eq!(format_value(2.26, Some(0.1)), "2.3");
        let dir = std::env::temp_dir().join(format!("fringe-labels-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join(LABELS);
        let header = COLUMNS.join(",");
        let cases = [
            (
                "a.png,0,0,x,0,0,0,0,NaN,NaN,None",
                "line 2: Fz = \"x\" is not a number",
            ),
            (
                "a.png,0,0,-3,0,0,0,3,NaN,NaN,pentagon",
                "presses a pentagon",
            ),
            (
                "../a.png,0,0,0,0,0,0,0,NaN,NaN,None",
                "not a file name inside 0.images/",
            ),
            (
                "a.png,0,0,2e5,0,0,0,0,NaN,NaN,None",
                "Fz = 2e5 is beyond 1e4",
            ),
        ];
        for (line, want) in cases {
            std::fs::write(&path, format!("{header}\n{line}\n")).expect("write");
            let e = read_labels(&path).expect_err(line).to_string();
            assert!(e.contains(want) && e.contains(LABELS), "{e}");
        }
        std::fs::write(&path, "New_Image_Name,Fz\na.png,0\n").expect("write");
        let e = read_labels(&path).expect_err("columns").to_string();
        assert!(e.contains("line 1: no column Fx"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
