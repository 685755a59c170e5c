//! A model adapted to one sensor unit without libtorch: the network's body is kept, its three
//! linear heads (force, shape, contact) are fitted again on the features the body gives for the
//! unit's labelled frames, each pulled towards the head it came with by an amount chosen by
//! cross-validation over presses (frames of one press never sit on both sides of a fold).
//!
//! What it reports is honest: the base heads' error on the frames (they never saw them) against
//! the fitted heads' cross-validated error (each press predicted by heads fitted without it).

#[cfg(feature = "torch")]
pub(crate) mod fine_tune;
pub(crate) mod head_fit;
pub(crate) mod held_out;
pub(crate) mod last_block;

pub use held_out::HeldOut;

use crate::backend::tract::TractGraph;
use crate::backend::InferenceError;
use crate::dataset::{Sample, Source};
use crate::eval::{for_each_batch, EvalError};
use crate::metrics::Scored;
use crate::model::Model;
use crate::onnx_graph::features_graph;
use crate::weights::state_dict::StateDict;
use crate::weights::tensor::Tensor;
use fringe_calibration::Profile;
use fringe_rig::seeded::SplitMix64;
use head_fit::{log_loss, ridge, softmax, Head};
use nalgebra::DMatrix;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// How the heads are fitted.
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptConfig {
    /// Cross-validation folds (over presses).
    pub folds: usize,
    /// Seed of the presses' assignment to folds.
    pub seed: u64,
    /// Inference threads for the features.
    pub threads: usize,
}

impl Default for AdaptConfig {
    fn default() -> Self {
        AdaptConfig {
            folds: 5,
            seed: 42,
            threads: 2,
        }
    }
}

/// The pulls towards the base heads that cross-validation chooses from, in samples' worth.
pub const PULLS: [f64; 8] = [0.001, 0.01, 0.1, 1.0, 10.0, 100.0, 1000.0, 10000.0];

/// Fewest presses to adapt on: every fold must leave presses to fit on.
pub const MIN_PRESSES: usize = 5;

/// One head's fit.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct HeadReport {
    /// `force_head`, `class_head` or `point_head`.
    pub head: &'static str,
    /// What the error figures measure.
    pub figure: &'static str,
    /// The base head on the frames.
    pub before: f64,
    /// The fitted head, cross-validated.
    pub after: f64,
    /// The pull chosen per output (one for the shape head).
    pub pull: Vec<f64>,
}

/// The adapted weights and how they were found.
#[derive(Debug, Clone)]
pub struct Adapted {
    pub weights: StateDict,
    pub frames: usize,
    pub presses: usize,
    pub heads: Vec<HeadReport>,
}

/// Why a model could not be adapted.
#[derive(Debug, thiserror::Error)]
pub enum AdaptError {
    #[error(transparent)]
    Eval(#[from] EvalError),
    #[error(
        "{0}: only the paper's networks can be adapted, from a weights file or an ONNX graph \
         that holds their weights by name (`fringe model export` writes one); this is another \
         graph or a TorchScript module"
    )]
    NotWeights(String),
    #[error(
        "{0}: the model has shear heads, and adaptation fits its force head again on the \
         F/T's magnitudes, which would undo them: fine-tune it with `fringe train --init` on \
         the unit's runs instead"
    )]
    ShearHeads(String),
    #[error("{path}: {source}")]
    Features {
        path: String,
        source: InferenceError,
    },
    #[error(
        "{presses} presses ({frames} frames) are too few to adapt on: at least {MIN_PRESSES} \
         presses, with contact, are needed"
    )]
    TooFew { presses: usize, frames: usize },
    #[error(
        "features of {got} values cannot join features of {have}: read every frame with the \
         same base model"
    )]
    Width { have: usize, got: usize },
    #[error("the {0} head could not be fitted (the features are degenerate)")]
    Singular(&'static str),
    #[error("{path}: {message}")]
    Saved { path: PathBuf, message: String },
}

/// The first bytes of a features file ([`Features::save`]).
const FEATURES_MAGIC: &[u8] = b"fringe-features\n";
/// Format of the features file this version writes; older ones are read, newer ones refused.
const FEATURES_FORMAT: u32 = 1;

/// A features file's header (JSON): the frames' labels, then `rows x cols` little-endian f32.
#[derive(serde::Serialize, serde::Deserialize)]
struct SavedHeader {
    format: u32,
    rows: usize,
    cols: usize,
    samples: Vec<Sample>,
    shapes: Vec<usize>,
}

/// The network body's features of labelled frames, beside their labels: read once, then fitted
/// on and predicted from as often as needed (commissioning adds each round's presses to them).
#[derive(Debug, Clone)]
pub struct Features {
    matrix: DMatrix<f64>,
    samples: Vec<Sample>,
    /// Each label's shape as an index into the model's classes.
    shapes: Vec<usize>,
}

impl Features {
    /// No frames yet.
    pub fn empty() -> Features {
        Features {
            matrix: DMatrix::zeros(0, 0),
            samples: Vec::new(),
            shapes: Vec::new(),
        }
    }

    /// Runs `model`'s body over every frame of `sources` (each preprocessed with its run's
    /// profile, else `profile`) on `threads` threads; `progress` hears (frames done, frames in
    /// all).
    pub fn read(
        model: &Model,
        sources: &[Source],
        profile: Option<&Profile>,
        threads: usize,
        progress: impl FnMut(usize, usize),
    ) -> Result<Features, AdaptError> {
        read_features(model, sources, profile, threads, progress)
    }

    /// Features already computed, with their labels (rows in the same order).
    pub(crate) fn from_parts(
        matrix: DMatrix<f64>,
        samples: Vec<Sample>,
        shapes: Vec<usize>,
    ) -> Features {
        Features {
            matrix,
            samples,
            shapes,
        }
    }

    /// Frames held.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// The frames' labels, in the order read.
    pub fn samples(&self) -> &[Sample] {
        &self.samples
    }

    /// Distinct presses among the frames.
    pub fn presses(&self) -> usize {
        let mut p: Vec<&str> = self.samples.iter().map(|s| s.press.as_str()).collect();
        p.sort_unstable();
        p.dedup();
        p.len()
    }

    /// Writes the features and their labels to `path` (whole or not at all), so that they are
    /// read once: a later fit or prediction [`Features::load`]s them instead of running the
    /// network again (commissioning keeps each round's).
    pub fn save(&self, path: &Path) -> Result<(), AdaptError> {
        let failed = |message: String| AdaptError::Saved {
            path: path.to_path_buf(),
            message,
        };
        let header = SavedHeader {
            format: FEATURES_FORMAT,
            rows: self.matrix.nrows(),
            cols: self.matrix.ncols(),
            samples: self.samples.clone(),
            shapes: self.shapes.clone(),
        };
        let json = serde_json::to_vec(&header).map_err(|e| failed(e.to_string()))?;
        let mut bytes =
            Vec::with_capacity(FEATURES_MAGIC.len() + 8 + json.len() + 4 * self.matrix.len());
        bytes.extend_from_slice(FEATURES_MAGIC);
        bytes.extend_from_slice(&(json.len() as u64).to_le_bytes());
        bytes.extend_from_slice(&json);
        for i in 0..self.matrix.nrows() {
            for j in 0..self.matrix.ncols() {
                // Read as f32 from the network: stored as it came, exactly.
                bytes.extend_from_slice(&(self.matrix[(i, j)] as f32).to_le_bytes());
            }
        }
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| failed(e.to_string()))?;
        }
        fringe_rig::store::write_atomic(path, &bytes).map_err(|e| failed(e.to_string()))
    }

    /// Reads features [`Features::save`] wrote.
    pub fn load(path: &Path) -> Result<Features, AdaptError> {
        let failed = |message: String| AdaptError::Saved {
            path: path.to_path_buf(),
            message,
        };
        let bytes = std::fs::read(path).map_err(|e| failed(e.to_string()))?;
        let rest = bytes
            .strip_prefix(FEATURES_MAGIC)
            .ok_or_else(|| failed("not a features file".into()))?;
        let damaged = || failed("damaged features file".into());
        let (len, rest) = rest.split_first_chunk::<8>().ok_or_else(damaged)?;
        let len = usize::try_from(u64::from_le_bytes(*len)).map_err(|_| damaged())?;
        if rest.len() < len {
            return Err(damaged());
        }
        let (json, values) = rest.split_at(len);
        #[derive(serde::Deserialize)]
        struct Format {
            format: u32,
        }
        let format: Format = serde_json::from_slice(json).map_err(|_| damaged())?;
        if format.format > FEATURES_FORMAT {
            return Err(failed(format!(
                "features format {} is newer than this fringe reads ({FEATURES_FORMAT})",
                format.format
            )));
        }
        let h: SavedHeader = serde_json::from_slice(json).map_err(|_| damaged())?;
        if h.samples.len() != h.rows
            || h.shapes.len() != h.rows
            || values.len() != 4 * h.rows * h.cols
        {
            return Err(damaged());
        }
        let value = |k: usize| {
            let b = [
                values[4 * k],
                values[4 * k + 1],
                values[4 * k + 2],
                values[4 * k + 3],
            ];
            f64::from(f32::from_le_bytes(b))
        };
        let cols = h.cols;
        Ok(Features {
            matrix: DMatrix::from_fn(h.rows, cols, |i, j| value(i * cols + j)),
            samples: h.samples,
            shapes: h.shapes,
        })
    }

    /// Adds `more`'s frames (read with the same model) after these.
    pub fn append(&mut self, more: Features) -> Result<(), AdaptError> {
        if self.is_empty() {
            *self = more;
            return Ok(());
        }
        if more.is_empty() {
            return Ok(());
        }
        if more.matrix.ncols() != self.matrix.ncols() {
            return Err(AdaptError::Width {
                have: self.matrix.ncols(),
                got: more.matrix.ncols(),
            });
        }
        let (a, b) = (self.matrix.nrows(), more.matrix.nrows());
        let width = self.matrix.ncols();
        let matrix = DMatrix::from_fn(a + b, width, |i, j| {
            if i < a {
                self.matrix[(i, j)]
            } else {
                more.matrix[(i - a, j)]
            }
        });
        self.matrix = matrix;
        self.samples.extend(more.samples);
        self.shapes.extend(more.shapes);
        Ok(())
    }
}

/// Adapts `model`'s heads to the frames of `sources` (each preprocessed with its run's profile,
/// else `profile`). `progress` hears (frames done, frames in all) while the features are read.
pub fn adapt_heads(
    model: &Model,
    sources: &[Source],
    profile: Option<&Profile>,
    config: &AdaptConfig,
    progress: impl FnMut(usize, usize),
) -> Result<Adapted, AdaptError> {
    let base = model
        .weights()
        .ok_or_else(|| AdaptError::NotWeights(model.path.display().to_string()))?;
    let features = read_features(model, sources, profile, config.threads, progress)?;
    fit_heads(base, &features, config)
}

/// The heads of `base` fitted again on `features`, each pulled towards its base head by
/// cross-validation over presses (`config`'s folds and seed).
pub fn fit_heads(
    base: &StateDict,
    features: &Features,
    config: &AdaptConfig,
) -> Result<Adapted, AdaptError> {
    let presses = features.presses();
    let in_contact = features
        .samples
        .iter()
        .filter(|s| s.contact.is_some())
        .count();
    if presses < MIN_PRESSES || in_contact == 0 {
        return Err(AdaptError::TooFew {
            presses,
            frames: features.len(),
        });
    }
    let table = Table {
        features: &features.matrix,
        samples: &features.samples,
        shapes: &features.shapes,
        fold: folds(&features.samples, config.folds.max(2), config.seed),
    };
    let mut weights = base.clone();
    let heads = vec![
        fit_force(&table, base, &mut weights)?,
        fit_shape(&table, base, &mut weights)?,
        fit_contact(&table, base, &mut weights)?,
    ];
    Ok(Adapted {
        weights,
        frames: features.len(),
        presses,
        heads,
    })
}

/// What the heads of `weights` predict for each frame of `features`, scored against its label
/// (the same figures the whole network gives: the heads are its last layers).
pub fn head_scores(weights: &StateDict, features: &Features) -> Result<Vec<Scored>, AdaptError> {
    let head = |name: &'static str| head_of(weights, name).ok_or(AdaptError::Singular(name));
    let (force, class, point) = (
        head("force_head")?,
        head("class_head")?,
        head("point_head")?,
    );
    let (f, c, p) = (
        force.apply(&features.matrix),
        class.apply(&features.matrix),
        point.apply(&features.matrix),
    );
    if f.ncols() < 3 || p.ncols() < 2 {
        return Err(AdaptError::Singular("force_head"));
    }
    Ok((0..features.len())
        .map(|i| {
            let s = &features.samples[i];
            Scored {
                fz_true: s.fz(),
                fz_pred: f[(i, 2)],
                shape_true: features.shapes[i],
                shape_pred: c.row(i).transpose().argmax().0,
                contact_true: s.contact,
                contact_pred: [p[(i, 0)], p[(i, 1)]],
                shear_true: None,
                shear_pred: None,
                slip_true: None,
                slip_pred: None,
            }
        })
        .collect())
}

/// The labelled frames' features and targets, with each frame's fold.
struct Table<'a> {
    features: &'a DMatrix<f64>,
    samples: &'a [Sample],
    shapes: &'a [usize],
    fold: Vec<usize>,
}

/// Runs the network's body over every frame.
fn read_features(
    model: &Model,
    sources: &[Source],
    profile: Option<&Profile>,
    threads: usize,
    progress: impl FnMut(usize, usize),
) -> Result<Features, AdaptError> {
    if model.has_shear() {
        return Err(AdaptError::ShearHeads(model.path.display().to_string()));
    }
    let proto = model
        .onnx()
        .ok()
        .and_then(features_graph)
        .ok_or_else(|| AdaptError::NotWeights(model.path.display().to_string()))?;
    let run = run_cut_graph(model, proto, sources, profile, threads, progress)?;
    let width = run.per_frame;
    let matrix = DMatrix::from_fn(run.samples.len(), width, |i, j| {
        f64::from(run.values[i * width + j])
    });
    Ok(Features {
        matrix,
        samples: run.samples,
        shapes: run.shapes,
    })
}

/// A cut of a network run over frames: its first output, frame after frame.
pub(crate) struct CutRun {
    pub values: Vec<f32>,
    /// Values per frame.
    pub per_frame: usize,
    pub samples: Vec<Sample>,
    pub shapes: Vec<usize>,
}

/// Runs `proto` (a graph cut from `model`'s network) over every frame of `sources`, each
/// preprocessed as evaluation does (its run's profile, else `profile`), on `threads` threads;
/// `progress` hears (frames done, frames in all). The one reading of a network's insides for
/// adaptation: the heads' features and the last block's inputs.
pub(crate) fn run_cut_graph(
    model: &Model,
    proto: tract_onnx::pb::ModelProto,
    sources: &[Source],
    profile: Option<&Profile>,
    threads: usize,
    mut progress: impl FnMut(usize, usize),
) -> Result<CutRun, AdaptError> {
    let err = |source| AdaptError::Features {
        path: model.path.display().to_string(),
        source,
    };
    let mut graph = TractGraph::new(proto, threads).map_err(err)?;
    let total: usize = sources.iter().map(|s| s.samples.len()).sum();
    let mut values = Vec::new();
    let (mut samples, mut shapes) = (Vec::with_capacity(total), Vec::with_capacity(total));
    let mut per_frame = 0;
    let mut failed = None;
    for_each_batch(model, sources, profile, None, false, |batch| {
        let n = batch.samples.len();
        let read = graph
            .run(&batch.input, n, model.input_size)
            .and_then(|out| {
                let flat = out.into_iter().next().unwrap_or_default();
                let per = flat.len() / n.max(1);
                if flat.is_empty() || flat.len() % n != 0 || (per_frame != 0 && per != per_frame) {
                    return Err(InferenceError::Outputs(format!(
                        "the network's values for {n} frames came as {} values",
                        flat.len()
                    )));
                }
                Ok(flat)
            });
        match read {
            Ok(flat) => {
                per_frame = flat.len() / n;
                values.extend(flat);
            }
            Err(e) => {
                failed = Some(e);
                return Err(EvalError::Image {
                    path: batch.samples[0].image.display().to_string(),
                    message: "the network's insides could not be read".into(),
                });
            }
        }
        samples.extend_from_slice(batch.samples);
        shapes.extend(batch.shapes);
        progress(samples.len(), total);
        Ok(())
    })
    .map_err(|e| match failed.take() {
        Some(source) => err(source),
        None => AdaptError::Eval(e),
    })?;
    Ok(CutRun {
        values,
        per_frame,
        samples,
        shapes,
    })
}

/// The presses of one fold (the first of `folds`, dealt with `seed`): presses to hold out.
pub fn held_out_presses(samples: &[Sample], folds: usize, seed: u64) -> Vec<String> {
    let fold = self::folds(samples, folds.max(2), seed);
    let mut presses: Vec<String> = samples
        .iter()
        .zip(&fold)
        .filter(|(_, f)| **f == 0)
        .map(|(s, _)| s.press.clone())
        .collect();
    presses.sort_unstable();
    presses.dedup();
    presses
}

/// Each frame's fold: presses shuffled with `seed` and dealt round the folds.
fn folds(samples: &[Sample], folds: usize, seed: u64) -> Vec<usize> {
    let mut presses: Vec<&str> = samples.iter().map(|s| s.press.as_str()).collect();
    presses.sort_unstable();
    presses.dedup();
    SplitMix64::new(seed).shuffle(&mut presses);
    let of: BTreeMap<&str, usize> = presses
        .iter()
        .enumerate()
        .map(|(i, p)| (*p, i % folds))
        .collect();
    samples
        .iter()
        .map(|s| of.get(s.press.as_str()).copied().unwrap_or(0))
        .collect()
}

/// A head of the state dict as a [`Head`].
fn head_of(sd: &StateDict, name: &str) -> Option<Head> {
    let w = sd.get(&format!("{name}.weight"))?;
    let b = sd.get(&format!("{name}.bias"))?;
    let (&out, &f) = (w.shape.first()?, w.shape.get(1)?);
    let weight = DMatrix::from_fn(out, f, |i, j| f64::from(w.data[i * f + j]));
    let bias = nalgebra::DVector::from_fn(out, |i, _| f64::from(b.data[i]));
    Some(Head { weight, bias })
}

/// Writes `head` into `sd` under `name`.
fn put_head(sd: &mut StateDict, name: &str, head: &Head) {
    let (out, f) = head.weight.shape();
    let w: Vec<f32> = (0..out)
        .flat_map(|i| (0..f).map(move |j| (i, j)))
        .map(|(i, j)| head.weight[(i, j)] as f32)
        .collect();
    let b: Vec<f32> = head.bias.iter().map(|&v| v as f32).collect();
    if let (Some(w), Some(b)) = (Tensor::new(vec![out, f], w), Tensor::new(vec![out], b)) {
        sd.insert(&format!("{name}.weight"), w);
        sd.insert(&format!("{name}.bias"), b);
    }
}

/// The rows of `m` at `idx`.
fn rows_of(m: &DMatrix<f64>, idx: &[usize]) -> DMatrix<f64> {
    DMatrix::from_fn(idx.len(), m.ncols(), |i, j| m[(idx[i], j)])
}

/// Ridge fits of `y` on `x` for each pull: the cross-validated squared error per output and
/// pull, and the fit on all rows per pull.
fn ridge_path(
    x: &DMatrix<f64>,
    y: &DMatrix<f64>,
    fold: &[usize],
    prior: &Head,
    name: &'static str,
) -> Result<(Vec<Vec<f64>>, Vec<Head>), AdaptError> {
    let folds = fold.iter().copied().max().map_or(0, |m| m + 1);
    let mut sse = vec![vec![0.0; y.ncols()]; PULLS.len()];
    let mut fits = Vec::with_capacity(PULLS.len());
    for (p, &pull) in PULLS.iter().enumerate() {
        for k in 0..folds {
            let (train, test): (Vec<usize>, Vec<usize>) =
                (0..fold.len()).partition(|&i| fold[i] != k);
            if train.is_empty() || test.is_empty() {
                continue;
            }
            let head = ridge(&rows_of(x, &train), &rows_of(y, &train), prior, pull)
                .ok_or(AdaptError::Singular(name))?;
            let err = head.apply(&rows_of(x, &test)) - rows_of(y, &test);
            for (o, col) in err.column_iter().enumerate() {
                sse[p][o] += col.norm_squared();
            }
        }
        fits.push(ridge(x, y, prior, pull).ok_or(AdaptError::Singular(name))?);
    }
    Ok((sse, fits))
}

/// Per output, the pull with the least cross-validated error; the head assembled from those
/// fits, and the chosen pulls.
fn choose_per_output(sse: &[Vec<f64>], fits: &[Head]) -> (Head, Vec<f64>, Vec<f64>) {
    let mut head = fits[0].clone();
    let outputs = head.outputs();
    let best_of = |o: usize| {
        (0..PULLS.len())
            .min_by(|&a, &b| sse[a][o].total_cmp(&sse[b][o]))
            .unwrap_or(0)
    };
    let chosen: Vec<usize> = (0..outputs).map(best_of).collect();
    for (o, &best) in chosen.iter().enumerate() {
        head.weight.set_row(o, &fits[best].weight.row(o));
        head.bias[o] = fits[best].bias[o];
    }
    let pulls = chosen.iter().map(|&b| PULLS[b]).collect();
    let best_sse = chosen.iter().enumerate().map(|(o, &b)| sse[b][o]).collect();
    (head, pulls, best_sse)
}

/// The force head: [Fx Fy Fz Mx My Mz Ft] on every frame; reported as Fz RMSE, N.
fn fit_force(
    t: &Table<'_>,
    base: &StateDict,
    out: &mut StateDict,
) -> Result<HeadReport, AdaptError> {
    const NAME: &str = "force_head";
    let prior = head_of(base, NAME).ok_or(AdaptError::Singular(NAME))?;
    let y = DMatrix::from_fn(t.samples.len(), 7, |i, j| t.samples[i].force[j]);
    let before = (prior.apply(t.features) - &y).column(2).norm_squared();
    let (sse, fits) = ridge_path(t.features, &y, &t.fold, &prior, NAME)?;
    let (head, pull, best) = choose_per_output(&sse, &fits);
    put_head(out, NAME, &head);
    let n = t.samples.len() as f64;
    Ok(HeadReport {
        head: NAME,
        figure: "Fz RMSE, N",
        before: (before / n).sqrt(),
        after: (best[2] / n).sqrt(),
        pull,
    })
}

/// The contact head: x, y on the frames in contact; reported as contact RMSE, mm.
fn fit_contact(
    t: &Table<'_>,
    base: &StateDict,
    out: &mut StateDict,
) -> Result<HeadReport, AdaptError> {
    const NAME: &str = "point_head";
    let prior = head_of(base, NAME).ok_or(AdaptError::Singular(NAME))?;
    let idx: Vec<usize> = (0..t.samples.len())
        .filter(|&i| t.samples[i].contact.is_some())
        .collect();
    let x = rows_of(t.features, &idx);
    let y = DMatrix::from_fn(idx.len(), 2, |i, j| {
        t.samples[idx[i]].contact.map_or(0.0, |c| c[j])
    });
    let fold: Vec<usize> = idx.iter().map(|&i| t.fold[i]).collect();
    let before = (prior.apply(&x) - &y).norm_squared();
    let (sse, fits) = ridge_path(&x, &y, &fold, &prior, NAME)?;
    let (head, pull, best) = choose_per_output(&sse, &fits);
    put_head(out, NAME, &head);
    let n = idx.len() as f64;
    Ok(HeadReport {
        head: NAME,
        figure: "contact RMSE, mm",
        before: (before / n).sqrt(),
        after: (best.iter().sum::<f64>() / n).sqrt(),
        pull,
    })
}

/// The shape head: softmax over the classes; the pull with the least cross-validated log loss;
/// reported as accuracy.
fn fit_shape(
    t: &Table<'_>,
    base: &StateDict,
    out: &mut StateDict,
) -> Result<HeadReport, AdaptError> {
    const NAME: &str = "class_head";
    let prior = head_of(base, NAME).ok_or(AdaptError::Singular(NAME))?;
    let folds = t.fold.iter().copied().max().map_or(0, |m| m + 1);
    let accuracy = |logits: &DMatrix<f64>, y: &[usize]| -> f64 {
        let right = (0..y.len())
            .filter(|&i| logits.row(i).transpose().argmax().0 == y[i])
            .count();
        right as f64 / y.len().max(1) as f64
    };
    let before = accuracy(&prior.apply(t.features), t.shapes);
    let mut best: Option<(f64, f64, f64)> = None; // (log loss, pull, accuracy)
    for &pull in &PULLS {
        let mut loss = 0.0;
        let mut right = 0.0;
        for k in 0..folds {
            let (train, test): (Vec<usize>, Vec<usize>) =
                (0..t.fold.len()).partition(|&i| t.fold[i] != k);
            if train.is_empty() || test.is_empty() {
                continue;
            }
            let ys = |idx: &[usize]| idx.iter().map(|&i| t.shapes[i]).collect::<Vec<_>>();
            let head = softmax(&rows_of(t.features, &train), &ys(&train), &prior, pull)
                .ok_or(AdaptError::Singular(NAME))?;
            let logits = head.apply(&rows_of(t.features, &test));
            loss += log_loss(&logits, &ys(&test)) * test.len() as f64;
            right += accuracy(&logits, &ys(&test)) * test.len() as f64;
        }
        let better = match best {
            Some((l, _, _)) => loss < l,
            None => true,
        };
        if better {
            best = Some((loss, pull, right / t.shapes.len().max(1) as f64));
        }
    }
    let (_, pull, after) = best.ok_or(AdaptError::Singular(NAME))?;
    let head = softmax(t.features, t.shapes, &prior, pull).ok_or(AdaptError::Singular(NAME))?;
    put_head(out, NAME, &head);
    Ok(HeadReport {
        head: NAME,
        figure: "shape accuracy",
        before,
        after,
        pull: vec![pull],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(press: &str) -> Sample {
        Sample {
            image: PathBuf::from(format!("{press}.png")),
            storage: None,
            force: [0.0; 7],
            shape: "None".into(),
            contact: None,
            shear: None,
            slip: None,
            press: press.into(),
            stage_mm: None,
        }
    }

    #[test]
    fn folds_keep_every_press_on_one_side_and_use_every_fold() {
        let samples: Vec<Sample> = (0..40).map(|i| sample(&format!("p{}", i / 4))).collect();
        let fold = folds(&samples, 5, 42);
        for (a, b) in samples.iter().zip(&fold) {
            for (c, d) in samples.iter().zip(&fold) {
                if a.press == c.press {
                    assert_eq!(b, d, "press {} in two folds", a.press);
                }
            }
        }
        let mut used: Vec<usize> = fold.clone();
        used.sort_unstable();
        used.dedup();
        assert_eq!(used, [0, 1, 2, 3, 4]);
        assert_eq!(fold, folds(&samples, 5, 42), "seeded");
        assert_ne!(fold, folds(&samples, 5, 43), "another seed deals otherwise");
    }

    /// Features saved are read back as they were (f32 values exactly, labels whole), and a
    /// file of a newer format or a damaged one is refused by name.
    #[test]
    fn saved_features_read_back_and_a_damaged_or_newer_file_is_refused() {
        let dir = std::env::temp_dir().join(format!("fringe-features-{}", std::process::id()));
        let path = dir.join("round-1.features");
        let mut samples: Vec<Sample> = (0..3).map(|i| sample(&format!("p{i}"))).collect();
        samples[1].contact = Some([1.25, -0.5]);
        samples[2].force[2] = 4.5;
        let matrix = DMatrix::from_fn(3, 4, |i, j| f64::from((i * 4 + j) as f32 * 0.1f32));
        let features = Features::from_parts(matrix, samples, vec![0, 1, 2]);
        features.save(&path).expect("save");
        let back = Features::load(&path).expect("load");
        assert_eq!(back.matrix, features.matrix);
        assert_eq!(back.samples, features.samples);
        assert_eq!(back.shapes, features.shapes);
        let bytes = std::fs::read(&path).expect("bytes");
        std::fs::write(&path, &bytes[..bytes.len() - 1]).expect("cut");
        let e = Features::load(&path).expect_err("cut").to_string();
        assert!(e.contains("damaged features file"), "{e}");
        let mut newer = bytes.clone();
        let at = newer
            .windows(10)
            .position(|w| w == b"\"format\":1")
            .expect("format in the header");
        newer[at + 9] = b'9';
        std::fs::write(&path, &newer).expect("newer");
        let e = Features::load(&path).expect_err("newer").to_string();
        assert!(e.contains("features format 9 is newer"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
