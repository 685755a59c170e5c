//! Training a network (`fringe train`): an architecture named on the command line, and (builds
//! with the cargo feature `torch`) the training itself: its settings checked, its data read
//! ([`prepare`]), then trained ([`Prepared::run`]); a training resumed from its checkpoint takes
//! the checkpoint's data and settings.

use fringe_sensor_models::Architecture;

/// The architecture named `s`; the error lists the names there are.
pub fn architecture(s: &str) -> Result<Architecture, String> {
    Architecture::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = Architecture::ALL.iter().map(|a| a.name()).collect();
        format!("unknown architecture `{s}`: use {}", names.join(", "))
    })
}

#[cfg(feature = "torch")]
pub use with_torch::{prepare, Prepared, ResumeError, TrainRequest, TrainingError};

#[cfg(feature = "torch")]
mod with_torch {
    use super::architecture;
    use fringe_calibration::{Profile, ProfileError};
    use fringe_sensor_models::dataset::{self, DatasetError, Source};
    use fringe_sensor_models::Architecture;
    use fringe_sensor_models::ModelFileError;
    use fringe_sensor_models::Pipeline;
    use fringe_sensor_models::Schedule;
    use fringe_sensor_models::{
        train, Checkpoint, TrainConfig, TrainError, TrainEvent, TrainOutcome as Outcome,
        TrainingRecord,
    };
    use fringe_sensor_models::{CardError, ModelCard};
    use std::path::{Path, PathBuf};
    use std::sync::atomic::AtomicBool;

    /// Epochs of a new training when none are asked for: the reference's.
    const EPOCHS: usize = 40;

    /// A training as the command line asks for it.
    pub struct TrainRequest {
        /// Run directories or reference-layout datasets (with `resume`, taken from the
        /// checkpoint's card when empty).
        pub data: Vec<PathBuf>,
        pub arch: Architecture,
        pub pipeline: Pipeline,
        /// Epochs (none: 40, or with `resume` the checkpoint's).
        pub epochs: Option<usize>,
        pub batch: usize,
        pub lr: f64,
        pub schedule: Schedule,
        pub seed: u64,
        pub input_size: u32,
        /// Checkpoints, split.json, loss.png and the final model go here.
        pub out: PathBuf,
        /// The checkpoint to continue from.
        pub resume: Option<PathBuf>,
        /// Calibration profile for datasets that carry none.
        pub profile: Option<PathBuf>,
        pub threads: usize,
        /// Weights to start from.
        pub init: Option<PathBuf>,
        /// A force network's window side, mm.
        pub force_window: Option<f64>,
        /// Train on every Nth frame of the training side.
        pub every: usize,
    }

    /// A training that cannot start or did not end.
    #[derive(Debug, thiserror::Error)]
    pub enum TrainingError {
        #[error("--epochs {0}: use 1 to 100000")]
        Epochs(usize),
        #[error("--batch {0}: use 1 to 4096")]
        Batch(usize),
        #[error("--lr {0}: use a learning rate above 0 and at most 1 (the reference uses 1e-3)")]
        LearningRate(f64),
        #[error("--input-size {0}: use 32 to 1024 px (the paper uses 224)")]
        InputSize(u32),
        #[error("--threads {0}: use 1 to 256")]
        Threads(usize),
        #[error("--every {0}: use 1 (every frame) to 10000")]
        Every(usize),
        #[error(
            "--force-window {mm}: use a window of {} to {} mm (24 mm holds a press of the 8 N range)",
            .range.start(),
            .range.end()
        )]
        ForceWindow {
            mm: f64,
            range: std::ops::RangeInclusive<f64>,
        },
        #[error("--init {}", .path.display())]
        Init {
            path: PathBuf,
            #[source]
            source: ModelFileError,
        },
        #[error(transparent)]
        Resume(#[from] ResumeError),
        #[error("no data: name one or more run directories or reference-layout datasets")]
        NoData,
        #[error(transparent)]
        Profile(#[from] ProfileError),
        /// Kept in the chain of causes as itself, for the front end that finds the command
        /// that helps with it.
        #[error("{0}")]
        Dataset(#[from] DatasetError),
        #[error(transparent)]
        Train(#[from] TrainError),
    }

    /// Refuses settings out of their ranges.
    fn check(r: &TrainRequest) -> Result<(), TrainingError> {
        if let Some(e) = r.epochs {
            if !(1..=100_000).contains(&e) {
                return Err(TrainingError::Epochs(e));
            }
        }
        if !(1..=4096).contains(&r.batch) {
            return Err(TrainingError::Batch(r.batch));
        }
        if !(r.lr.is_finite() && r.lr > 0.0 && r.lr <= 1.0) {
            return Err(TrainingError::LearningRate(r.lr));
        }
        if !(32..=1024).contains(&r.input_size) {
            return Err(TrainingError::InputSize(r.input_size));
        }
        if !(1..=10_000).contains(&r.every) {
            return Err(TrainingError::Every(r.every));
        }
        if !(1..=256).contains(&r.threads) {
            return Err(TrainingError::Threads(r.threads));
        }
        if let Some(mm) = r.force_window {
            let range = fringe_sensor_models::FORCE_WINDOW_MM;
            if !range.contains(&mm) {
                return Err(TrainingError::ForceWindow { mm, range });
            }
        }
        Ok(())
    }

    /// A training ready to run: its settings checked and complete, its data read.
    pub struct Prepared {
        pub config: TrainConfig,
        sources: Vec<Source>,
        profile: Option<Profile>,
        resume: Option<PathBuf>,
    }

    /// Checks the settings of `r`, takes a resumed training's data and settings from its
    /// checkpoint, and reads every dataset; `read` hears each dataset read (as named, and what
    /// it holds).
    pub fn prepare(
        r: TrainRequest,
        read: &mut dyn FnMut(&Path, &Source),
    ) -> Result<Prepared, TrainingError> {
        check(&r)?;
        if let Some(init) = &r.init {
            // Read before the data is prepared: a wrong file is found in a second, not minutes.
            fringe_sensor_models::read_weights(init).map_err(|source| TrainingError::Init {
                path: init.clone(),
                source,
            })?;
        }
        let mut config = TrainConfig {
            arch: r.arch,
            pipeline: r.pipeline,
            epochs: r.epochs.unwrap_or(EPOCHS),
            batch: r.batch,
            lr: r.lr,
            schedule: r.schedule,
            seed: r.seed,
            input_size: r.input_size,
            threads: r.threads,
            out: r.out,
            init: r.init,
            split: None,
            augment: true,
            freeze_batch_norm: false,
            force_window_mm: r.force_window,
            every: r.every,
        };
        let mut data = r.data;
        if let Some(cp) = &r.resume {
            resume_settings(cp, r.epochs, &mut config, &mut data)?;
        }
        if data.is_empty() {
            return Err(TrainingError::NoData);
        }
        let profile = match &r.profile {
            Some(p) => Some(Profile::load(p)?),
            None => None,
        };
        let mut sources = Vec::with_capacity(data.len());
        for d in &data {
            let s = dataset::read(d)?;
            read(d, &s);
            sources.push(s);
        }
        Ok(Prepared {
            config,
            sources,
            profile,
            resume: r.resume,
        })
    }

    impl Prepared {
        /// Trains (or resumes); `stop` ends it after the current batch with a checkpoint to
        /// resume from; `events` hears its progress.
        pub fn run(
            &self,
            stop: &AtomicBool,
            events: &mut dyn FnMut(TrainEvent),
        ) -> Result<Outcome, TrainingError> {
            Ok(train(
                &self.config,
                &self.sources,
                self.profile.as_ref(),
                self.resume.as_deref(),
                stop,
                events,
            )?)
        }
    }

    /// A checkpoint a training cannot resume from.
    #[derive(Debug, thiserror::Error)]
    pub enum ResumeError {
        #[error("--resume {}: no such checkpoint", .0.display())]
        NoCheckpoint(PathBuf),
        #[error(transparent)]
        Card(#[from] CardError),
        #[error(transparent)]
        Record(#[from] serde_json::Error),
        #[error("{}: not a checkpoint written by fringe train (its card has no training record)", .0.display())]
        NoRecord(PathBuf),
        #[error("--resume {}: the checkpoint was trained on {then:?}, not {now:?}: resume with the same data (or none, to take it from the checkpoint)", checkpoint.display())]
        OtherData {
            checkpoint: PathBuf,
            then: Vec<PathBuf>,
            now: Vec<PathBuf>,
        },
        #[error("{0}")]
        Architecture(String),
    }

    /// Takes the data (when none is named) and the settings from checkpoint `cp`'s card;
    /// `epochs` (--epochs) may extend the training.
    fn resume_settings(
        cp: &Path,
        epochs: Option<usize>,
        config: &mut TrainConfig,
        data: &mut Vec<PathBuf>,
    ) -> Result<(), ResumeError> {
        if !cp.is_file() {
            return Err(ResumeError::NoCheckpoint(cp.to_path_buf()));
        }
        let card = ModelCard::read(&Checkpoint::at(cp).card())?;
        let record: TrainingRecord = card
            .other
            .get("training")
            .cloned()
            .map(serde_json::from_value)
            .transpose()?
            .ok_or_else(|| ResumeError::NoRecord(cp.to_path_buf()))?;
        if data.is_empty() {
            *data = record.data.clone();
        } else if *data != record.data {
            return Err(ResumeError::OtherData {
                checkpoint: cp.to_path_buf(),
                then: record.data,
                now: data.clone(),
            });
        }
        // Settings come from the checkpoint; --epochs may extend the training.
        config.pipeline = record.pipeline;
        config.augment = record.augmented;
        config.freeze_batch_norm = record.batch_norm_frozen;
        config.batch = record.batch;
        config.lr = record.lr;
        config.schedule = record.schedule;
        config.seed = record.seed;
        config.force_window_mm = record.force_window_mm;
        config.every = record.every;
        if let Some(arch) = card.architecture.as_deref() {
            config.arch = architecture(arch).map_err(ResumeError::Architecture)?;
        }
        if let Some(size) = card.input_size {
            config.input_size = size;
        }
        config.out = cp
            .parent()
            .map(PathBuf::from)
            .unwrap_or_else(|| PathBuf::from("."));
        config.epochs = epochs.unwrap_or(record.epochs);
        Ok(())
    }
}
