//! The training loop: the reference's loss (MSE on Fz + cross-entropy on the shape + MSE on the
//! contact over the rows in contact, equal weights; and, where the data knows it, MSE on the
//! signed shear from the force head's Fx, Fy, weighted [`SHEAR_WEIGHT`]) and optimiser (Adam, lr 1e-3, batch 32),
//! the split by press, checkpoints every 2 epochs and at the end, an interrupted epoch saved
//! where it stopped, and resume that continues exactly: the same split, copies, batch order
//! (shuffled from the seed and the epoch), weights and optimiser state.

use super::adam::Adam;
use super::checkpoint::{Checkpoint, EpochRecord, TrainingRecord};
use super::error::TrainError;
use crate::arch::Architecture;
use crate::augment::Pipeline;
use crate::contact_window::ContactWindow;
use crate::dataset::Source;
use crate::metrics::{Errors, Scored};
use crate::model_card::ModelCard;
use crate::preprocess::Preprocessing;
use crate::split::{Side, Split, SplitSpec};
use crate::torch_net::state::{load_state_dict, state_dict};
use crate::torch_net::Net;
use crate::training_set::{Item, TrainingSet, WINDOW_JITTER_MM};
use crate::weights::state_dict::StateDict;
use fringe_calibration::Profile;
use fringe_plot::palette::{BLUE, ORANGE};
use fringe_plot::{Axis, Chart, Series};
use fringe_rig::reference_layout::NO_CONTACT;
use fringe_rig::seeded::{mix, SplitMix64};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;
use tch::{Device, Reduction, Tensor};

/// What to train and how.
#[derive(Debug, Clone)]
pub struct TrainConfig {
    pub arch: Architecture,
    pub pipeline: Pipeline,
    pub epochs: usize,
    pub batch: usize,
    pub lr: f64,
    /// How the rate changes over the epochs.
    pub schedule: crate::lr_schedule::Schedule,
    pub seed: u64,
    pub input_size: u32,
    /// Threads for libtorch and for preparing the data.
    pub threads: usize,
    pub out: PathBuf,
    /// Weights to start from instead of a random initialisation (fine-tuning a trained model:
    /// any weights file `fringe model` reads, of the same architecture and classes).
    pub init: Option<PathBuf>,
    /// The split to train with, by press, instead of a new one from `seed` (a fine-tuning that
    /// must keep a fold of presses out of training). A resumed training keeps its own.
    pub split: Option<Split>,
    /// Training inputs are the pipeline's augmented copies of each frame; else each frame once
    /// as recorded (fine-tuning to one unit, whose fixed optical pattern turning would blur).
    pub augment: bool,
    /// Batch norm keeps the running statistics of `init` (fine-tuning on a small set).
    pub freeze_batch_norm: bool,
    /// Train the force network of a two-stage model: it reads the force (and, as the keypoint
    /// CNN, where the press lies from the window's centre: [`TrainConfig::reads_contact_offset`])
    /// from a window of this side (mm) about the contact, on the frames in contact (every side's
    /// windows centred on the labelled contact moved by
    /// [`crate::training_set::WINDOW_JITTER_MM`], as the first network finds it).
    pub force_window_mm: Option<f64>,
    /// Train on every Nth frame of the training side (1: all): the frames of a 50 Hz run a
    /// frame apart differ little, and a tenth of them trains as well in a tenth of the time.
    pub every: usize,
}

impl TrainConfig {
    /// A force network that also reads where the press lies from its window's centre: one of
    /// an architecture that keeps positions (the keypoint CNN's soft-argmax maps). The custom
    /// CNN's and ResNet-18's global average keeps none: trained on the offset, it moved the
    /// contact little and its force only lost (BENCHMARKS.md, "The force network reads the
    /// contact too").
    pub fn reads_contact_offset(&self) -> bool {
        self.force_window_mm.is_some() && self.arch.keypoints().is_some()
    }
}

/// What the loop tells its caller, for progress and messages.
#[derive(Debug, Clone)]
pub enum TrainEvent {
    /// The split is made (or read back on resume).
    Split {
        train: usize,
        val: usize,
        test: usize,
        path: PathBuf,
    },
    /// Frames of a side read and preprocessed.
    Preparing {
        side: &'static str,
        done: usize,
        total: usize,
    },
    Batch {
        epoch: usize,
        epochs: usize,
        batch: usize,
        batches: usize,
        loss: f64,
        images_per_second: f64,
    },
    Epoch(EpochRecord),
    Checkpoint(PathBuf),
    /// The final model evaluated on the test side.
    Evaluating {
        done: usize,
        total: usize,
    },
}

/// How a training ended.
#[derive(Debug)]
pub enum Outcome {
    /// All epochs trained: the final model and its test figures (fringe eval's).
    Finished {
        model: PathBuf,
        evaluation: crate::eval::Evaluation,
    },
    /// All epochs of a force network trained (`force_window_mm`): the model and its figures
    /// on the test side's windows (about the labelled contact, moved by the jitter).
    ForceNetwork {
        model: PathBuf,
        test_frames: usize,
        fz_rmse_n: f64,
        /// The contact, the window's centre moved by the offset the network reads, mm (a
        /// network that reads no offset: none).
        contact_rmse_mm: Option<f64>,
        /// The contact the window's centre alone gives (the jitter's RMSE), mm.
        centre_rmse_mm: f64,
    },
    /// Stopped (Ctrl-C): the checkpoint to resume from.
    Interrupted { checkpoint: PathBuf },
}

/// Every labelled frame with its preprocessing and mirror flag, and what the geometry came from.
struct Frames<'a> {
    items: Vec<(usize, usize)>,
    preprocessing: Vec<Preprocessing>,
    mirror: Vec<bool>,
    /// Each source's force window (`force_window_mm` trainings).
    windows: Vec<Option<ContactWindow>>,
    profiles: Vec<String>,
    /// The sensor design every source that says one names (they must agree).
    design: Option<String>,
    sources: &'a [Source],
}

impl Frames<'_> {
    fn sample(&self, i: usize) -> &crate::dataset::Sample {
        let (s, k) = self.items[i];
        &self.sources[s].samples[k]
    }

    fn item(&self, i: usize) -> Item<'_> {
        let (s, _) = self.items[i];
        Item {
            sample: self.sample(i),
            preprocessing: &self.preprocessing[s],
            mirror: self.mirror[s],
            window: self.windows[s],
        }
    }
}

fn frames<'a>(
    sources: &'a [Source],
    fallback: Option<&Profile>,
    config: &TrainConfig,
) -> Result<Frames<'a>, TrainError> {
    let mut f = Frames {
        items: Vec::new(),
        preprocessing: Vec::new(),
        mirror: Vec::new(),
        windows: Vec::new(),
        profiles: Vec::new(),
        design: None,
        sources,
    };
    // A model reads one sensor design: sources of two are refused before anything is read.
    let mut named: Option<&Source> = None;
    for source in sources {
        let (Some(first), Some(v)) = (named, source.variant.as_deref()) else {
            if source.variant.is_some() {
                named = Some(source);
            }
            continue;
        };
        let design = first.variant.as_deref().unwrap_or_default();
        if v != design {
            return Err(TrainError::MixedDesigns {
                first: first.path.display().to_string(),
                design: design.to_string(),
                other: source.path.display().to_string(),
                other_design: v.to_string(),
            });
        }
    }
    f.design = named.and_then(|s| s.variant.clone());
    for (si, source) in sources.iter().enumerate() {
        let path = source.path.display().to_string();
        let profile = source
            .profile
            .as_ref()
            .or(fallback)
            .ok_or_else(|| TrainError::NoProfile { path: path.clone() })?;
        let pre = Preprocessing::from_profile(profile, config.pipeline.colour(), config.input_size)
            .map_err(|source| TrainError::Profile {
                path: path.clone(),
                source,
            })?;
        f.preprocessing.push(pre);
        let window = config
            .force_window_mm
            .map(|mm| ContactWindow::from_profile(profile, mm))
            .transpose()
            .map_err(|source| TrainError::Window {
                path: path.clone(),
                source,
            })?;
        f.windows.push(window);
        f.mirror
            .push(profile.registration.as_ref().is_some_and(|r| r.mirror));
        f.profiles.push(format!(
            "{path}: sensor {} ({})",
            profile.sensor_id, profile.source
        ));
        f.items.extend((0..source.samples.len()).map(|k| (si, k)));
    }
    if f.items.is_empty() {
        let names: Vec<String> = sources
            .iter()
            .map(|s| s.path.display().to_string())
            .collect();
        return Err(TrainError::NoFrames(names.join(", ")));
    }
    Ok(f)
}

/// "None", then the shape names of the data in sorted order (the reference's class order).
fn classes(f: &Frames<'_>) -> Vec<String> {
    let mut names: Vec<String> = (0..f.items.len())
        .map(|i| f.sample(i).shape.clone())
        .filter(|s| s != NO_CONTACT)
        .collect();
    names.sort();
    names.dedup();
    std::iter::once(NO_CONTACT.to_string())
        .chain(names)
        .collect()
}

/// The classes a training learns: the data's, or, fine-tuning (`init`), the starting model's
/// when they hold the data's (a model of pentagons and rectangles fine-tuned on slides of the
/// pentagon keeps its rectangle; its shape head has a row for each).
fn init_classes(init: Option<&Path>, data: Vec<String>) -> Vec<String> {
    let card = init.and_then(|p| ModelCard::find(p).ok().flatten());
    match card.and_then(|(c, _)| c.classes) {
        Some(known) if data.iter().all(|c| known.contains(c)) && known.first() == data.first() => {
            known
        }
        _ => data,
    }
}

/// The weight of a force network's contact term (its offset from the window's centre, mm
/// squared) against the force's (N squared): the offsets are a few tenths of a millimetre, and
/// at equal weights the force's term drowned them. Measured on the layered design (BENCHMARKS.md,
/// "The force network reads the contact too"): at 10 the window's keypoint CNN read the contact
/// 0.20 mm from the truth where the window's centre was 0.98 mm off, at 1 only 0.70 mm.
const WINDOW_CONTACT_WEIGHT: f64 = 10.0;

/// The weight of the shear term (N squared) against Fz's (N squared, of labels rounded to
/// 0.1 N): the shear is read to a few hundredths of a newton (issue 65's 0.05 N), and its errors'
/// squares are an order of magnitude under Fz's.
const SHEAR_WEIGHT: f64 = 4.0;

/// What a training's loss trains.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Heads {
    /// A whole-disc network: force, shape and contact.
    Disc,
    /// A force network: the force, and, when `offset`, where the press lies from the window's
    /// centre (its contact head), weighted [`WINDOW_CONTACT_WEIGHT`]; no shape.
    Window { offset: bool },
}

impl Heads {
    /// The heads `config` trains.
    fn of(config: &TrainConfig) -> Heads {
        match config.force_window_mm {
            None => Heads::Disc,
            Some(_) => Heads::Window {
                offset: config.reads_contact_offset(),
            },
        }
    }
}

/// The losses of a batch, summed: for a whole-disc network the force's, the shape's and the
/// contact's; for a force network the force's and, when it reads it, the contact offset's.
fn loss(
    net: &Net,
    set: &TrainingSet,
    idx: &[usize],
    buf: &mut Vec<f32>,
    train: bool,
    heads: Heads,
) -> (Tensor, Vec<Scored>) {
    set.batch(idx, buf);
    let s = set.input_size as i64;
    let x = Tensor::from_slice(buf).view([idx.len() as i64, 3, s, s]);
    let out = net.forward(&x, train);
    let targets: Vec<_> = idx.iter().map(|&i| set.targets[i]).collect();
    let fz: Vec<f32> = targets.iter().map(|t| t.fz).collect();
    let class: Vec<i64> = targets.iter().map(|t| t.class).collect();
    let fz_pred = out.force.select(1, 2);
    let mut l = fz_pred.mse_loss(&Tensor::from_slice(&fz), Reduction::Mean);
    // The force head's Fx, Fy learn the signed shear on the rows whose data knows it.
    let sheared: Vec<i64> = (0..targets.len() as i64)
        .filter(|&r| targets[r as usize].shear.is_some())
        .collect();
    let shear_pred = (!sheared.is_empty()).then(|| {
        out.force
            .index_select(0, &Tensor::from_slice(&sheared))
            .narrow(1, 0, 2)
    });
    if let Some(pred) = &shear_pred {
        let q: Vec<f32> = targets.iter().filter_map(|t| t.shear).flatten().collect();
        l += pred.mse_loss(&Tensor::from_slice(&q).view([-1, 2]), Reduction::Mean) * SHEAR_WEIGHT;
    }
    if heads == Heads::Disc {
        l += out
            .logits
            .cross_entropy_for_logits(&Tensor::from_slice(&class));
    }
    let rows: Vec<i64> = (0..targets.len() as i64)
        .filter(|&r| targets[r as usize].contact.is_some())
        .collect();
    let contact_weight = match heads {
        Heads::Disc => Some(1.0),
        Heads::Window { offset: true } => Some(WINDOW_CONTACT_WEIGHT),
        Heads::Window { offset: false } => None,
    };
    if let (Some(w), false) = (contact_weight, rows.is_empty()) {
        let xy: Vec<f32> = targets.iter().filter_map(|t| t.contact).flatten().collect();
        let pred = out.point.index_select(0, &Tensor::from_slice(&rows));
        l += pred.mse_loss(&Tensor::from_slice(&xy).view([-1, 2]), Reduction::Mean) * w;
    }
    let scored = if train {
        Vec::new()
    } else {
        let fz_p = Vec::<f32>::try_from(&fz_pred.detach()).unwrap_or_default();
        let cls = Vec::<i64>::try_from(&out.logits.argmax(1, false)).unwrap_or_default();
        let pt =
            Vec::<f32>::try_from(&out.point.detach().contiguous().view([-1])).unwrap_or_default();
        let fxy = Vec::<f32>::try_from(&out.force.detach().narrow(1, 0, 2).contiguous().view([-1]))
            .unwrap_or_default();
        (0..targets.len())
            .filter(|&r| r < fz_p.len() && r < cls.len() && 2 * r + 1 < pt.len())
            .map(|r| Scored {
                fz_true: f64::from(targets[r].fz),
                fz_pred: f64::from(fz_p[r]),
                shape_true: targets[r].class as usize,
                shape_pred: cls[r] as usize,
                contact_true: targets[r]
                    .contact
                    .map(|c| [f64::from(c[0]), f64::from(c[1])]),
                contact_pred: [f64::from(pt[2 * r]), f64::from(pt[2 * r + 1])],
                shear_true: targets[r].shear.map(|t| t.map(f64::from)),
                shear_pred: fxy
                    .get(2 * r..2 * r + 2)
                    .map(|p| [f64::from(p[0]), f64::from(p[1])]),
                slip_true: None,
                slip_pred: None,
            })
            .collect()
    };
    (l, scored)
}

/// The validation side's loss and Table-2 errors, in evaluation mode.
fn validate(net: &Net, set: &TrainingSet, heads: Heads) -> (f64, Errors) {
    let mut errors = Errors::default();
    let mut sum = 0.0;
    let mut n = 0;
    let mut buf = Vec::new();
    let all: Vec<usize> = (0..set.len()).collect();
    tch::no_grad(|| {
        for chunk in all.chunks(64) {
            let (l, scored) = loss(net, set, chunk, &mut buf, false, heads);
            sum += l.double_value(&[]) * chunk.len() as f64;
            n += chunk.len();
            for s in &scored {
                errors.add(s);
            }
        }
    });
    (if n > 0 { sum / n as f64 } else { f64::NAN }, errors)
}

/// The batch order of an epoch: the training inputs shuffled from the seed and the epoch.
fn order(n: usize, seed: u64, epoch: usize) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..n).collect();
    SplitMix64::new(mix(seed ^ 0x7472_6169_6e00, epoch as u64)).shuffle(&mut idx);
    idx
}

#[allow(clippy::too_many_arguments)]
fn card_for(
    config: &TrainConfig,
    classes: &[String],
    f: &Frames<'_>,
    record: &TrainingRecord,
) -> ModelCard {
    let sensors: Vec<&str> = f.preprocessing.iter().map(|p| p.sensor.as_str()).collect();
    let mut card = ModelCard {
        architecture: Some(config.arch.name().to_string()),
        classes: Some(classes.to_vec()),
        input_size: Some(config.input_size),
        colour: Some(config.pipeline.colour()),
        preprocessing: Some("profile".to_string()),
        sensor_id: sensors.first().map(|s| s.to_string()),
        // The data's design (runs and `fringe sim dataset` datasets record it); without it
        // `fringe model info` shows the card as of unknown design.
        variant: f.design.clone(),
        crop_diameter_px: f.preprocessing.first().map(|p| 2.0 * p.crop_radius_px),
        frame_size: f
            .preprocessing
            .first()
            .and_then(|p| p.frame_size)
            .map(|(w, h)| [w, h]),
        force_window_mm: config.force_window_mm,
        refines_contact: Heads::of(config) == Heads::Window { offset: true },
        force_model: None,
        contact_model: None,
        // The data knows the shear: the loss trained the force head's Fx, Fy on it.
        shear: (0..f.items.len()).any(|i| f.sample(i).shear.is_some()),
        slip: None,
        other: serde_json::Map::new(),
    };
    if let Ok(v) = serde_json::to_value(record) {
        card.other.insert("training".into(), v);
    }
    card
}

/// Trains on `sources` (each with its run's profile, else `fallback`), or resumes from the
/// checkpoint `resume`. `stop` (Ctrl-C) ends the loop after the current batch with a
/// checkpoint to resume from.
pub fn train(
    config: &TrainConfig,
    sources: &[Source],
    fallback: Option<&Profile>,
    resume: Option<&Path>,
    stop: &AtomicBool,
    events: &mut dyn FnMut(TrainEvent),
) -> Result<Outcome, TrainError> {
    set_up(config)?;
    let f = frames(sources, fallback, config)?;
    let classes = init_classes(config.init.as_deref(), classes(&f));
    let samples: Vec<crate::dataset::Sample> =
        (0..f.items.len()).map(|i| f.sample(i).clone()).collect();
    let split_path = config.out.join("split.json");
    let resumed = match resume {
        Some(p) => Some(Checkpoint::at(p).read()?),
        None => None,
    };
    let split = match &resumed {
        // A resumed training keeps its split.
        Some((_, _, record, _)) => resumed_split(resume, record)?,
        None => match &config.split {
            Some(given) => {
                given.save(&split_path)?;
                given.clone()
            }
            None => new_split(&samples, config.seed, &split_path)?,
        },
    };
    let mut sides = Sides::of(&split, &samples)?;
    if config.force_window_mm.is_some() {
        // A force network reads presses: the frames without contact have no window.
        sides = sides.in_contact(&samples)?;
    }
    if config.every > 1 {
        sides.train = sides.train.into_iter().step_by(config.every).collect();
        sides.check()?;
    }
    events(TrainEvent::Split {
        train: sides.train.len(),
        val: sides.val.len(),
        test: sides.test.len(),
        path: split_path.clone(),
    });
    let prepare = |idx: &[usize], pipeline, side, events: &mut dyn FnMut(TrainEvent)| {
        let items: Vec<Item<'_>> = idx.iter().map(|&i| f.item(i)).collect();
        let side = SideToPrepare {
            items: &items,
            pipeline,
            name: side,
        };
        prepare_side(config, &classes, side, stop, events)
    };
    let train_set = prepare(
        &sides.train,
        config.augment.then_some(config.pipeline),
        "training",
        events,
    )?;
    let val_set = prepare(&sides.val, None, "validation", events)?;

    let record = first_record(config, sources, &sides, train_set.len(), &f);
    let mut run = Run::new(config, &classes, &f, record);
    run.load_start(resume, resumed.as_ref())?;
    if let Some(checkpoint) = run.epochs(&train_set, &val_set, stop, events)? {
        return Ok(Outcome::Interrupted { checkpoint });
    }
    run.finish(sources, &split, &sides.test, fallback, events)
}

/// libtorch's threads and seed set, and the output directory made.
fn set_up(config: &TrainConfig) -> Result<(), TrainError> {
    tch::set_num_threads(config.threads.max(1) as i32);
    tch::manual_seed(config.seed as i64);
    std::fs::create_dir_all(&config.out).map_err(|source| TrainError::Write {
        path: config.out.display().to_string(),
        source,
    })
}

/// The split a resumed training was made with, read from beside its checkpoint `resume`.
fn resumed_split(resume: Option<&Path>, record: &TrainingRecord) -> Result<Split, TrainError> {
    let path = resume
        .and_then(Path::parent)
        .map_or_else(|| record.split.clone(), |d| d.join(&record.split));
    Ok(Split::load(&path)?)
}

/// The frame indices of the split's three sides.
#[derive(Debug)]
struct Sides {
    train: Vec<usize>,
    val: Vec<usize>,
    test: Vec<usize>,
}

impl Sides {
    /// The frames of each side whose label has a contact, each side checked to keep one.
    fn in_contact(self, samples: &[crate::dataset::Sample]) -> Result<Sides, TrainError> {
        let keep = |v: Vec<usize>| -> Vec<usize> {
            v.into_iter()
                .filter(|&i| samples[i].contact.is_some())
                .collect()
        };
        let sides = Sides {
            train: keep(self.train),
            val: keep(self.val),
            test: keep(self.test),
        };
        sides.check()?;
        Ok(sides)
    }

    /// The sides of `split` over `samples`, each checked to hold a frame.
    fn of(split: &Split, samples: &[crate::dataset::Sample]) -> Result<Sides, TrainError> {
        let side = |s: Side| split.indices(samples, s);
        let sides = Sides {
            train: side(Side::Train),
            val: side(Side::Val),
            test: side(Side::Test),
        };
        sides.check()?;
        Ok(sides)
    }

    /// Refuses a side without a frame, naming it.
    fn check(&self) -> Result<(), TrainError> {
        for (name, v) in [
            ("training", &self.train),
            ("validation", &self.val),
            ("test", &self.test),
        ] {
            if v.is_empty() {
                return Err(TrainError::EmptySide(name));
            }
        }
        Ok(())
    }
}

/// The record of a training not yet started: its data and settings, no epoch trained.
fn first_record(
    config: &TrainConfig,
    sources: &[Source],
    sides: &Sides,
    train_inputs: usize,
    f: &Frames<'_>,
) -> TrainingRecord {
    TrainingRecord {
        data: sources.iter().map(|s| s.path.clone()).collect(),
        split: PathBuf::from("split.json"),
        pipeline: config.pipeline,
        augmented: config.augment,
        batch_norm_frozen: config.freeze_batch_norm,
        epochs: config.epochs,
        batch: config.batch,
        lr: config.lr,
        schedule: config.schedule,
        seed: config.seed,
        epoch: 0,
        batch_in_epoch: 0,
        loss_sum_in_epoch: 0.0,
        batches_trained: 0,
        train_frames: sides.train.len(),
        train_inputs,
        val_frames: sides.val.len(),
        test_frames: sides.test.len(),
        profiles: f.profiles.clone(),
        history: Vec::new(),
        evaluation: None,
        init: None,
        force_window_mm: config.force_window_mm,
        every: config.every,
    }
}

/// What [`Checkpoint::read`] gives back: weights, card, training record, optimiser state.
type Resumed = (StateDict, ModelCard, TrainingRecord, StateDict);

/// A training under way: the network, its optimiser and the record its checkpoints carry.
struct Run<'a> {
    config: &'a TrainConfig,
    classes: &'a [String],
    frames: &'a Frames<'a>,
    vs: tch::nn::VarStore,
    net: Net,
    adam: Adam,
    record: TrainingRecord,
}

impl<'a> Run<'a> {
    /// A network freshly initialised (from libtorch's seed) with its optimiser.
    fn new(
        config: &'a TrainConfig,
        classes: &'a [String],
        frames: &'a Frames<'a>,
        record: TrainingRecord,
    ) -> Run<'a> {
        let vs = tch::nn::VarStore::new(Device::cuda_if_available());
        let mut net = Net::new(&vs.root(), config.arch, classes.len());
        if config.freeze_batch_norm {
            net.freeze_batch_norm();
        }
        let adam = Adam::new(&vs, config.lr);
        Run {
            config,
            classes,
            frames,
            vs,
            net,
            adam,
            record,
        }
    }

    /// Loads the weights to start from: `--init`'s for a new training; for one resumed from
    /// the checkpoint `resume`, its weights, optimiser state and progress.
    fn load_start(
        &mut self,
        resume: Option<&Path>,
        resumed: Option<&Resumed>,
    ) -> Result<(), TrainError> {
        if let (Some(init), None) = (&self.config.init, resumed) {
            let what = init.display().to_string();
            let weights = crate::weights::format::read_weights(init)?;
            load_state_dict(&self.vs, &weights, &what)?;
            self.record.init = Some(init.clone());
        }
        if let Some((weights, _, r, opt)) = resumed {
            let what = resume.map(|p| p.display().to_string()).unwrap_or_default();
            load_state_dict(&self.vs, weights, &what)?;
            self.adam.restore(opt, &what)?;
            self.record.epoch = r.epoch;
            self.record.batch_in_epoch = r.batch_in_epoch;
            self.record.loss_sum_in_epoch = r.loss_sum_in_epoch;
            self.record.batches_trained = r.batches_trained;
            self.record.history = r.history.clone();
            self.record.init = r.init.clone();
        }
        Ok(())
    }

    /// Trains the epochs that remain, validating and checkpointing after each; the checkpoint
    /// to resume from when `stop` ended it early.
    fn epochs(
        &mut self,
        train_set: &TrainingSet,
        val_set: &TrainingSet,
        stop: &AtomicBool,
        events: &mut dyn FnMut(TrainEvent),
    ) -> Result<Option<PathBuf>, TrainError> {
        let batches = train_set.len().div_ceil(self.config.batch.max(1));
        let mut buf = Vec::new();
        while self.record.epoch < self.config.epochs {
            self.adam.set_lr(self.epoch_lr());
            let started = Instant::now();
            let images = match self.batches(train_set, batches, started, &mut buf, stop, events)? {
                ControlFlow::Continue(images) => images,
                ControlFlow::Break(checkpoint) => return Ok(Some(checkpoint)),
            };
            self.end_epoch(val_set, batches, images, started, events)?;
            if let Some(checkpoint) = self.epoch_checkpoint(stop, events)? {
                return Ok(Some(checkpoint));
            }
        }
        Ok(None)
    }

    /// The batches of the current epoch from where it stands: the number of images trained,
    /// or the checkpoint written when `stop` interrupted the epoch.
    fn batches(
        &mut self,
        train_set: &TrainingSet,
        batches: usize,
        started: Instant,
        buf: &mut Vec<f32>,
        stop: &AtomicBool,
        events: &mut dyn FnMut(TrainEvent),
    ) -> Result<ControlFlow<PathBuf, usize>, TrainError> {
        let epoch = self.record.epoch;
        let batch = self.config.batch;
        let idx = order(train_set.len(), self.config.seed, epoch);
        let mut images = 0usize;
        for b in self.record.batch_in_epoch..batches {
            let chunk = &idx[b * batch..((b + 1) * batch).min(idx.len())];
            let lv = self.step(train_set, chunk, buf);
            self.record.loss_sum_in_epoch += lv;
            self.record.batch_in_epoch = b + 1;
            self.record.batches_trained += 1;
            images += chunk.len();
            events(TrainEvent::Batch {
                epoch: epoch + 1,
                epochs: self.config.epochs,
                batch: b + 1,
                batches,
                loss: lv,
                images_per_second: images as f64 / started.elapsed().as_secs_f64().max(1e-9),
            });
            if stop.load(Ordering::Relaxed) && b + 1 < batches {
                let name = format!("checkpoint_epoch_{}_batch_{}", epoch + 1, b + 1);
                let cp = self.write_checkpoint(&name)?;
                return Ok(ControlFlow::Break(cp.weights));
            }
        }
        Ok(ControlFlow::Continue(images))
    }

    /// The learning rate of the current epoch.
    fn epoch_lr(&self) -> f64 {
        self.config
            .schedule
            .lr(self.config.lr, self.record.epoch, self.config.epochs)
    }

    /// One optimiser step on the inputs `chunk`; the batch's loss.
    fn step(&mut self, train_set: &TrainingSet, chunk: &[usize], buf: &mut Vec<f32>) -> f64 {
        self.adam.zero_grad();
        let (l, _) = loss(
            &self.net,
            train_set,
            chunk,
            buf,
            true,
            Heads::of(self.config),
        );
        l.backward();
        self.adam.step();
        l.double_value(&[])
    }

    /// Closes an epoch: validates, records its figures, reports them and redraws `loss.png`.
    fn end_epoch(
        &mut self,
        val_set: &TrainingSet,
        batches: usize,
        images: usize,
        started: Instant,
        events: &mut dyn FnMut(TrainEvent),
    ) -> Result<(), TrainError> {
        let (val_loss, errors) = validate(&self.net, val_set, Heads::of(self.config));
        let seconds = started.elapsed().as_secs_f64();
        let er = EpochRecord {
            epoch: self.record.epoch + 1,
            train_loss: self.record.loss_sum_in_epoch / batches.max(1) as f64,
            val_loss,
            val_fz_rmse_n: errors.fz_rmse(),
            val_contact_rmse_mm: errors.contact_rmse(),
            val_shape_accuracy: errors.accuracy(),
            val_shear_rmse_n: errors.shear_rmse(),
            lr: Some(self.epoch_lr()),
            seconds,
            images_per_second: images as f64 / seconds.max(1e-9),
        };
        self.record.history.push(er.clone());
        self.record.epoch += 1;
        self.record.batch_in_epoch = 0;
        self.record.loss_sum_in_epoch = 0.0;
        events(TrainEvent::Epoch(er));
        plot_losses(&self.config.out, &self.record.history)
    }

    /// The checkpoint after an epoch (every second one, the last, or when stopping); the
    /// checkpoint to resume from when `stop` ends the training before its last epoch.
    fn epoch_checkpoint(
        &mut self,
        stop: &AtomicBool,
        events: &mut dyn FnMut(TrainEvent),
    ) -> Result<Option<PathBuf>, TrainError> {
        let last = self.record.epoch == self.config.epochs;
        if self.record.epoch.is_multiple_of(2) || last || stop.load(Ordering::Relaxed) {
            let cp = self.write_checkpoint(&format!("checkpoint_epoch_{}", self.record.epoch))?;
            events(TrainEvent::Checkpoint(cp.weights.clone()));
            if stop.load(Ordering::Relaxed) && !last {
                return Ok(Some(cp.weights));
            }
        }
        Ok(None)
    }

    /// Writes the checkpoint `name` (weights, card and optimiser state) in the output directory.
    fn write_checkpoint(&self, name: &str) -> Result<Checkpoint, TrainError> {
        let cp = Checkpoint::new(&self.config.out, name);
        let card = card_for(self.config, self.classes, self.frames, &self.record);
        cp.write(
            &state_dict(&self.vs, self.record.batches_trained)?,
            &card,
            Some(&self.adam.state()?),
        )?;
        Ok(cp)
    }

    /// The final model, evaluated on the test side by fringe eval's own evaluation (the default
    /// backend reading the file just written: the checkpoint is checked to load and run), then
    /// written again with the test figures in its card.
    fn finish(
        mut self,
        sources: &[Source],
        split: &Split,
        test: &[usize],
        fallback: Option<&Profile>,
        events: &mut dyn FnMut(TrainEvent),
    ) -> Result<Outcome, TrainError> {
        if self.config.force_window_mm.is_some() {
            return self.finish_force(test, events);
        }
        let final_cp = Checkpoint::new(&self.config.out, "model");
        let card = card_for(self.config, self.classes, self.frames, &self.record);
        let weights = state_dict(&self.vs, self.record.batches_trained)?;
        final_cp.write(&weights, &card, Some(&self.adam.state()?))?;
        let evaluation = evaluate_on_test(
            &final_cp.weights,
            self.config,
            sources,
            split,
            fallback,
            events,
        )?;
        self.record.evaluation = Some(test_figures(&evaluation));
        let card = card_for(self.config, self.classes, self.frames, &self.record);
        final_cp.write(&weights, &card, Some(&self.adam.state()?))?;
        Ok(Outcome::Finished {
            model: final_cp.weights,
            evaluation,
        })
    }
}

impl Run<'_> {
    /// The final force network, with its test figures: Fz and the contact on the test side's
    /// windows about the labelled contact moved by the jitter (the network alone; `fringe eval`
    /// of the two-stage model gives the figures with the contact the first network finds).
    fn finish_force(
        mut self,
        test: &[usize],
        events: &mut dyn FnMut(TrainEvent),
    ) -> Result<Outcome, TrainError> {
        let final_cp = Checkpoint::new(&self.config.out, "model");
        let weights = state_dict(&self.vs, self.record.batches_trained)?;
        let stop = AtomicBool::new(false);
        let items: Vec<Item<'_>> = test.iter().map(|&i| self.frames.item(i)).collect();
        let side = SideToPrepare {
            items: &items,
            pipeline: None,
            name: "test",
        };
        let test_set = prepare_side(self.config, self.classes, side, &stop, events)?;
        let (_, errors) = validate(&self.net, &test_set, Heads::of(self.config));
        let contact_rmse_mm = self
            .config
            .reads_contact_offset()
            .then(|| errors.contact_rmse());
        let offsets: Vec<f64> = test_set
            .targets
            .iter()
            .filter_map(|t| t.contact)
            .map(|[x, y]| f64::from(x).powi(2) + f64::from(y).powi(2))
            .collect();
        let centre_rmse_mm = (offsets.iter().sum::<f64>() / offsets.len().max(1) as f64).sqrt();
        self.record.evaluation = Some(serde_json::json!({
            "side": "test",
            "frames": errors.n,
            "fz_rmse_n": errors.fz_rmse(),
            "contact_rmse_mm": contact_rmse_mm,
            "window_centre": format!(
                "the labelled contact moved by {WINDOW_JITTER_MM} mm per axis \
                 ({centre_rmse_mm:.3} mm RMS)"
            ),
        }));
        let card = card_for(self.config, self.classes, self.frames, &self.record);
        final_cp.write(&weights, &card, Some(&self.adam.state()?))?;
        Ok(Outcome::ForceNetwork {
            model: final_cp.weights,
            test_frames: errors.n as usize,
            fz_rmse_n: errors.fz_rmse(),
            contact_rmse_mm,
            centre_rmse_mm,
        })
    }
}

/// The test-side figures the final card records under `training.evaluation`.
fn test_figures(evaluation: &crate::eval::Evaluation) -> serde_json::Value {
    let m = &evaluation.metrics;
    serde_json::json!({
        "side": "test",
        "frames": m.all.n,
        "fz_mse_n2": m.all.fz_mse(),
        "fz_rmse_n": m.all.fz_rmse(),
        "contact_rmse_mm": m.all.contact_rmse(),
        "shape_accuracy": m.all.accuracy(),
        "macro": m.macro_scores(),
        "shear_rmse_n": m.all.shear_rmse(),
    })
}

/// A new split by press of `samples`, saved to `path`.
fn new_split(
    samples: &[crate::dataset::Sample],
    seed: u64,
    path: &Path,
) -> Result<Split, TrainError> {
    let split = Split::new(
        samples,
        SplitSpec {
            seed,
            ..SplitSpec::default()
        },
    )?;
    split.save(path)?;
    Ok(split)
}

/// One side of the split to prepare: its items, its augmentation pipeline (none for
/// validation), its name for progress.
struct SideToPrepare<'a, 'b> {
    items: &'a [Item<'b>],
    pipeline: Option<Pipeline>,
    name: &'static str,
}

/// The network inputs of one side, prepared on `config.threads` threads while the progress is
/// reported on this one.
fn prepare_side(
    config: &TrainConfig,
    classes: &[String],
    side: SideToPrepare<'_, '_>,
    stop: &AtomicBool,
    events: &mut dyn FnMut(TrainEvent),
) -> Result<TrainingSet, crate::training_set::TrainingSetError> {
    let (tx, rx) = std::sync::mpsc::channel();
    let result = std::thread::scope(|scope| {
        let h = scope.spawn(|| {
            TrainingSet::prepare(
                side.items,
                classes,
                side.pipeline,
                config.pipeline.colour(),
                config.input_size,
                config.seed,
                config.threads,
                stop,
                &move |done, total| {
                    let _ = tx.send((done, total));
                },
            )
        });
        for (done, total) in rx {
            events(TrainEvent::Preparing {
                side: side.name,
                done,
                total,
            });
        }
        h.join()
    });
    result.unwrap_or(Err(crate::training_set::TrainingSetError::Stopped))
}

/// The model written to `weights` evaluated on the test side of `split` by the default backend
/// (the file just written is checked to load and run), as `fringe eval` evaluates.
fn evaluate_on_test(
    weights: &Path,
    config: &TrainConfig,
    sources: &[Source],
    split: &Split,
    fallback: Option<&Profile>,
    events: &mut dyn FnMut(TrainEvent),
) -> Result<crate::eval::Evaluation, TrainError> {
    let model = crate::model::Model::open(weights)?;
    let mut predictor = crate::predictor::Predictor::new(
        &model,
        crate::backend::BackendKind::Tract,
        config.threads.max(1),
    )?;
    let test_sources: Vec<Source> = sources
        .iter()
        .map(|s| Source {
            samples: s
                .samples
                .iter()
                .filter(|x| split.side_of(&x.press) == Some(Side::Test))
                .cloned()
                .collect(),
            ..s.clone()
        })
        .collect();
    Ok(crate::eval::evaluate(
        &model,
        &mut predictor,
        &test_sources,
        fallback,
        None,
        |done, total| events(TrainEvent::Evaluating { done, total }),
    )?)
}

/// `loss.png`: training and validation loss by epoch.
fn plot_losses(dir: &Path, history: &[EpochRecord]) -> Result<(), TrainError> {
    let train: Vec<[f64; 2]> = history
        .iter()
        .map(|h| [h.epoch as f64, h.train_loss])
        .collect();
    let val: Vec<[f64; 2]> = history
        .iter()
        .map(|h| [h.epoch as f64, h.val_loss])
        .collect();
    let img = Chart::new(
        "Loss by epoch",
        Axis::new("epoch").integers(),
        Axis::new("loss (sum of the heads' losses, no unit)").from_zero(),
    )
    .series(Series::line("training", &train, BLUE).with_markers())
    .series(Series::line("validation", &val, ORANGE).with_markers())
    .render(720, 720);
    let path = dir.join("loss.png");
    let failed = |e: &dyn std::fmt::Display| TrainError::Write {
        path: path.display().to_string(),
        source: std::io::Error::other(e.to_string()),
    };
    img.map_err(|e| failed(&e))?
        .save(&path)
        .map_err(|e| failed(&e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lr_schedule::Schedule;

    fn source(path: &str, variant: Option<&str>) -> Source {
        Source {
            path: PathBuf::from(path),
            samples: Vec::new(),
            profile: None,
            sensor_id: None,
            variant: variant.map(String::from),
            skipped: 0,
        }
    }

    /// Data of two sensor designs is refused before anything is read, naming both; data that
    /// does not say its design goes with the one that does.
    #[test]
    fn data_of_two_sensor_designs_is_refused_naming_both() {
        let config = TrainConfig {
            arch: Architecture::Keypoint,
            pipeline: Pipeline::Gray10,
            epochs: 1,
            batch: 32,
            lr: 1e-3,
            schedule: Schedule::Constant,
            seed: 42,
            input_size: 112,
            threads: 1,
            out: PathBuf::from("out"),
            init: None,
            split: None,
            augment: true,
            freeze_batch_norm: false,
            force_window_mm: None,
            every: 1,
        };
        let sources = [
            source("runs/a", Some("layered")),
            source("old-run", None),
            source("ds-int", Some("integrated")),
        ];
        let e = frames(&sources, None, &config)
            .err()
            .expect("two designs refused");
        let msg = e.to_string();
        assert!(
            msg.contains("runs/a is of the layered sensor design and ds-int of the integrated")
                && msg.contains("one model per design"),
            "{msg}"
        );
        // One design (and a source that does not say): on to the profiles.
        let e = frames(&sources[..2], None, &config)
            .err()
            .expect("no profile");
        assert!(matches!(e, TrainError::NoProfile { .. }), "{e}");
    }
}
