//! A model as users have it: a weights file (`.pth`, `.pt`, `.safetensors`) or an ONNX graph,
//! with its optional model card (`<file>.json`), ready to run on a backend.

use crate::arch::{default_class_names, recognise, ArchError, Architecture};
use crate::backend::tract::{output_order, TractBackend};
use crate::backend::{Backend, BackendKind, InferenceError};
use crate::model_card::{CardError, CardSource, ModelCard, CARD_METADATA_KEY};
use crate::onnx_graph;
use crate::preprocess::{
    Colour, PreprocessError, Preprocessing, ReferenceSensor, DEFAULT_INPUT_SIZE, INPUT_SIZES,
};
use crate::weights::error::ModelFileError;
use crate::weights::format::read_weights;
use crate::weights::safetensors_file::card_in_safetensors;
use crate::weights::state_dict::StateDict;
use crate::weights::tensor::Tensor;
use fringe_calibration::Profile;
use std::path::{Path, PathBuf};
use tract_onnx::pb;
use tract_onnx::prelude::Framework;

/// Frames whose sensor crop is narrower than this fraction of the training frames' crop are
/// warned about.
const SCALE_TOLERANCE: f64 = 0.75;

/// Why a model could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    #[error(transparent)]
    File(#[from] ModelFileError),
    #[error("{path}: {source}")]
    Arch { path: String, source: ArchError },
    #[error("{path}: not an ONNX model ({detail})")]
    Onnx { path: String, detail: String },
    #[error(transparent)]
    Card(#[from] CardError),
    #[error("{path}: {detail}")]
    Classes { path: String, detail: String },
    #[error("{path}: {detail}")]
    InputSize { path: String, detail: String },
    #[error(
        "no calibration profile for {path}: pass --profile profiles/ID.toml (the sensor's \
         calibration), or --reference-preprocessing for a model the reference code trained"
    )]
    NoGeometry { path: String },
    #[error("{path}: the model card's preprocessing \"{name}\" is unknown (profile, reference-layered, reference-integrated)")]
    CardPreprocessing { path: String, name: String },
    #[error(transparent)]
    Preprocess(#[from] PreprocessError),
    #[error(
        "builtin:{name}: no such built-in model (fringe has: {known}; `default` is the first)"
    )]
    UnknownBuiltin { name: String, known: String },
    #[error(
        "{path}: a TorchScript module runs only on the torch backend (--backend torch); for \
         {backend}, export it to ONNX with torch.onnx.export or save its state_dict()"
    )]
    TorchScriptOnly { path: String, backend: BackendKind },
    #[error(
        "{path}: an ONNX graph runs on tract or onnxruntime; the torch backend runs weights \
         files (.pth, .pt, .safetensors) and TorchScript modules"
    )]
    NotForTorch { path: String },
    #[error("{path}: {source}")]
    Backend {
        path: String,
        source: InferenceError,
    },
    #[error(
        "no model ships for the {design} sensor design (fringe ships models for: {known}): give \
         --model with one trained for it (`fringe train`) or commission the unit"
    )]
    NoneShipped { design: String, known: String },
    #[error(
        "{path}: a window network of a two-stage model (its card has force_window_mm): it reads \
         a window about a contact another network finds; run the model whose card names it as \
         force_model or contact_model (`fringe model pair` makes one)"
    )]
    WindowNetworkAlone { path: String },
    #[error(
        "{path}: the model has no shear heads (its card does not say \"shear\": true), so it \
         cannot give the tangential force; train one on runs that record shear (`fringe scan \
         slides`, then `fringe train RUN...`), or leave shear out"
    )]
    NoShearHeads { path: String },
    #[error(
        "{path}: named as a window network (force_model, contact_model) of {of}, but its card \
         gives no force_window_mm: name a network trained with `fringe train --force-window`"
    )]
    NotAWindowNetwork { path: String, of: String },
    #[error(
        "{path}: named as the contact network (contact_model) of {of}, but its card does not \
         say refines_contact: name a network trained with `fringe train --arch keypoint \
         --force-window MM`"
    )]
    NotAContactNetwork { path: String, of: String },
    #[error(
        "{path}: the model is for the {design} sensor design and {what} is {variant}: its \
         figures there mean nothing; give a model of the {variant} design"
    )]
    OtherDesign {
        path: String,
        design: String,
        variant: String,
        what: String,
    },
}

/// Where the model came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// Weights of one of the paper's networks (any file format).
    Weights,
    /// An ONNX graph from elsewhere.
    Onnx,
    /// A TorchScript module (`torch.jit.save`; the torch backend only).
    TorchScript,
}

/// What runs: an ONNX graph (built from the weights, or the file's), or a TorchScript archive
/// that only libtorch runs.
#[derive(Debug, Clone)]
enum Graph {
    Onnx(Box<pb::ModelProto>),
    #[cfg_attr(not(feature = "torch"), allow(dead_code))]
    TorchScript,
}

/// A model ready to run.
#[derive(Debug, Clone)]
pub struct Model {
    pub path: PathBuf,
    pub source: Source,
    /// The paper's network the weights are, when recognised.
    pub arch: Option<Architecture>,
    /// Shape class names, "None" first.
    pub classes: Vec<String>,
    /// Trainable parameters.
    pub parameters: usize,
    /// Element types in the file ("f32", "f16", ...).
    pub stored: String,
    pub input_size: u32,
    pub colour: Colour,
    pub card: Option<ModelCard>,
    /// Where the card came from (the JSON beside the file, the file's own metadata, ...).
    pub card_source: CardSource,
    graph: Graph,
    /// The weights, when the model was read from a weights file (what adaptation starts from).
    weights: Option<std::sync::Arc<StateDict>>,
    /// A two-stage model's force network (its card's `force_model`), attached by
    /// [`crate::builtin::open`].
    pub force: Option<Box<Model>>,
    /// A two-stage model's window network that places the contact (its card's
    /// `contact_model`), attached by [`crate::builtin::open`].
    pub contact_refiner: Option<Box<Model>>,
}

impl Model {
    /// Opens a model file. Its card is the JSON beside it (`<file>.json` or `<stem>.json`), else
    /// the one in the file's own metadata (a safetensors header's `__metadata__`, an ONNX
    /// graph's `metadata_props`, both under `fringe.model_card`).
    pub fn open(path: &Path) -> Result<Model, ModelError> {
        let beside = ModelCard::find(path)?;
        let shown = path.display().to_string();
        let is_onnx = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("onnx"));
        if !is_onnx {
            let (card, card_source) = match beside {
                Some((card, at)) => (Some(card), CardSource::Beside(at)),
                None => match card_in_safetensors(path)? {
                    Some(card) => (Some(card), CardSource::Embedded),
                    None => (None, CardSource::Missing),
                },
            };
            return match read_weights(path) {
                Ok(sd) => Model::from_weights(path, sd, card, card_source),
                #[cfg(feature = "torch")]
                Err(ModelFileError {
                    kind: crate::weights::error::ModelFileErrorKind::TorchScript,
                    ..
                }) => Model::open_torchscript(path, card, card_source),
                Err(e) => Err(e.into()),
            };
        }
        let proto =
            tract_onnx::onnx()
                .proto_model_for_path(path)
                .map_err(|e| ModelError::Onnx {
                    path: shown.clone(),
                    detail: format!("{e:#}"),
                })?;
        output_order(&proto).map_err(|source| ModelError::Backend {
            path: shown.clone(),
            source,
        })?;
        let (card, card_source) = match beside {
            Some((card, at)) => (Some(card), CardSource::Beside(at)),
            None => match proto
                .metadata_props
                .iter()
                .find(|p| p.key == CARD_METADATA_KEY)
            {
                Some(p) => (
                    Some(ModelCard::embedded(path, &p.value)?),
                    CardSource::Embedded,
                ),
                None => (None, CardSource::Missing),
            },
        };
        let sd = initializers(&proto);
        let recognised = recognise(&sd).ok();
        let classes = match recognised {
            Some((_, c)) => Some(c),
            None => logits_width(&proto),
        };
        let n = classes.ok_or_else(|| ModelError::Classes {
            path: shown.clone(),
            detail: "the shape_logits output has no fixed width: say how many classes in \
                         the model card (\"classes\": [...])"
                .into(),
        })?;
        let card_size = card.as_ref().and_then(|c| c.input_size);
        let declared = declared_input(&proto);
        let mut model = Model::assemble(
            path,
            Source::Onnx,
            recognised.map(|r| r.0),
            n,
            &sd,
            Graph::Onnx(Box::new(proto)),
            card,
            card_source,
        )?;
        // The input side the graph declares, when it fixes one: without a card it is the size
        // to run it at (not the 224 px guess), and a card must agree with it.
        match (card_size, declared) {
            (_, None) => {}
            (Some(c), Some([h, w])) if (h, w) != (c, c) => {
                return Err(ModelError::InputSize {
                    path: shown,
                    detail: format!(
                        "the model card says input_size {c} px but the graph's input is {h} x \
                         {w} px: correct the card"
                    ),
                })
            }
            (Some(_), Some(_)) => {}
            (None, Some([h, w])) if h != w => {
                return Err(ModelError::InputSize {
                    path: shown,
                    detail: format!(
                        "the graph's input is {h} x {w} px, but fringe's inputs are square: \
                         export the network with a square input"
                    ),
                })
            }
            (None, Some([side, _])) if !INPUT_SIZES.contains(&side) => {
                return Err(ModelError::InputSize {
                    path: shown,
                    detail: format!(
                        "the graph's input is {side} x {side} px, outside the {} to {} px \
                         fringe's preprocessing makes",
                        INPUT_SIZES.start(),
                        INPUT_SIZES.end()
                    ),
                })
            }
            (None, Some([side, _])) => model.input_size = side,
        }
        // A graph of one of the paper's networks holds every weight under its state-dict name.
        if recognised.is_some() {
            model.weights = Some(std::sync::Arc::new(sd));
        }
        Ok(model)
    }

    /// A model from weights already read (`path` names them in messages), with its card and
    /// where the card came from.
    pub fn from_weights(
        path: &Path,
        sd: StateDict,
        card: Option<ModelCard>,
        card_source: CardSource,
    ) -> Result<Model, ModelError> {
        let (arch, n) = recognise(&sd).map_err(|source| ModelError::Arch {
            path: path.display().to_string(),
            source,
        })?;
        let proto = onnx_graph::build(arch, n, &sd);
        let mut model = Model::assemble(
            path,
            Source::Weights,
            Some(arch),
            n,
            &sd,
            Graph::Onnx(Box::new(proto)),
            card,
            card_source,
        )?;
        model.weights = Some(std::sync::Arc::new(sd));
        Ok(model)
    }

    /// When this is a two-stage model, what a copy of it (export, adaptation) leaves behind.
    pub fn copy_warning(&self) -> Option<String> {
        let windows: Vec<String> = [&self.force, &self.contact_refiner]
            .into_iter()
            .flatten()
            .map(|w| w.path.display().to_string())
            .collect();
        (!windows.is_empty()).then(|| {
            format!(
                "{} is a two-stage model: the copy is of its first network alone (contact and \
                 shape, and its own force head); its window networks ({}) stay where they are \
                 (join them again with `fringe model pair`)",
                self.path.display(),
                windows.join(", ")
            )
        })
    }

    /// The window side (mm) a force network reads about the contact (its card's
    /// `force_window_mm`); `None` for a whole-disc network.
    pub fn force_window_mm(&self) -> Option<f64> {
        self.card.as_ref().and_then(|c| c.force_window_mm)
    }

    /// Refuses a window network on its own (its card has `force_window_mm`): it reads a window
    /// about a contact another network finds, so whole frames given to it mean nothing. The one
    /// rule for everything that runs or adapts a model on whole frames.
    pub fn check_runs_alone(&self) -> Result<(), ModelError> {
        if self.force_window_mm().is_some() {
            return Err(ModelError::WindowNetworkAlone {
                path: self.path.display().to_string(),
            });
        }
        Ok(())
    }

    /// Whether the force the model gives carries the signed shear: the card's `shear` of the
    /// network that reads the force (a two-stage model's force network).
    pub fn has_shear(&self) -> bool {
        let reads_force = self.force.as_deref().unwrap_or(self);
        reads_force.card.as_ref().is_some_and(|c| c.shear)
    }

    /// The model's slip head (its card's `slip`), when it has shear heads to feed it.
    pub fn slip_head(&self) -> Option<crate::slip_head::SlipHead> {
        self.card
            .as_ref()
            .and_then(|c| c.slip.clone())
            .filter(|_| self.has_shear())
    }

    /// Refuses a model without shear heads where the tangential force is asked for.
    pub fn require_shear(&self) -> Result<(), ModelError> {
        if self.has_shear() {
            Ok(())
        } else {
            Err(ModelError::NoShearHeads {
                path: self.path.display().to_string(),
            })
        }
    }

    /// The weights by name, when the model is one of the paper's networks: a weights file, or
    /// an ONNX graph that holds them under their state-dict names (as `fringe model export`
    /// writes it); not another graph, not a TorchScript module.
    pub fn weights(&self) -> Option<&StateDict> {
        self.weights.as_deref()
    }

    /// A TorchScript archive, loaded by libtorch once to find its shape classes.
    #[cfg(feature = "torch")]
    fn open_torchscript(
        path: &Path,
        card: Option<ModelCard>,
        card_source: CardSource,
    ) -> Result<Model, ModelError> {
        let size = card
            .as_ref()
            .and_then(|c| c.input_size)
            .unwrap_or(DEFAULT_INPUT_SIZE);
        let named = card.as_ref().and_then(|c| c.classes.as_ref()).map(Vec::len);
        let probe = crate::backend::torch::TorchBackend::from_script(path, named, size, 1)
            .map_err(|source| ModelError::Backend {
                path: path.display().to_string(),
                source,
            })?;
        let mut m = Model::assemble(
            path,
            Source::TorchScript,
            None,
            probe.classes(),
            &StateDict::new(),
            Graph::TorchScript,
            card,
            card_source,
        )?;
        m.parameters = probe.parameters();
        m.stored = "TorchScript".into();
        Ok(m)
    }

    #[allow(clippy::too_many_arguments)]
    fn assemble(
        path: &Path,
        source: Source,
        arch: Option<Architecture>,
        n_classes: usize,
        sd: &StateDict,
        graph: Graph,
        card: Option<ModelCard>,
        card_source: CardSource,
    ) -> Result<Model, ModelError> {
        let shown = path.display().to_string();
        let classes = match card.as_ref().and_then(|c| c.classes.clone()) {
            Some(names) if names.len() != n_classes => {
                return Err(ModelError::Classes {
                    path: shown,
                    detail: format!(
                        "the model card names {} shape classes but the network has {n_classes}",
                        names.len()
                    ),
                })
            }
            Some(names) => names,
            None => default_class_names(n_classes),
        };
        Ok(Model {
            path: path.to_path_buf(),
            source,
            arch,
            classes,
            parameters: sd.parameter_count(),
            stored: sd.stored_types(),
            input_size: card
                .as_ref()
                .and_then(|c| c.input_size)
                .unwrap_or(DEFAULT_INPUT_SIZE),
            colour: card.as_ref().and_then(|c| c.colour).unwrap_or(Colour::Grey),
            card,
            card_source,
            graph,
            weights: None,
            force: None,
            contact_refiner: None,
        })
    }

    /// The ONNX graph (for a weights file, the one built from them); a TorchScript module has
    /// none.
    pub fn onnx(&self) -> Result<&pb::ModelProto, ModelError> {
        match &self.graph {
            Graph::Onnx(p) => Ok(p),
            Graph::TorchScript => Err(ModelError::TorchScriptOnly {
                path: self.path.display().to_string(),
                backend: BackendKind::Tract,
            }),
        }
    }

    fn onnx_for(&self, backend: BackendKind) -> Result<&pb::ModelProto, ModelError> {
        self.onnx().map_err(|_| ModelError::TorchScriptOnly {
            path: self.path.display().to_string(),
            backend,
        })
    }

    /// The backend `kind` on `threads` threads; a backend this build lacks is an error saying
    /// how to build it in.
    pub fn backend(
        &self,
        kind: BackendKind,
        threads: usize,
    ) -> Result<Box<dyn Backend>, ModelError> {
        match kind {
            BackendKind::Tract => self.tract(threads),
            #[cfg(feature = "onnxruntime")]
            BackendKind::OnnxRuntime => self.onnxruntime(threads),
            #[cfg(feature = "torch")]
            BackendKind::Torch => self.torch(threads),
            #[cfg(not(all(feature = "onnxruntime", feature = "torch")))]
            #[allow(unreachable_patterns)]
            _ => Err(ModelError::Backend {
                path: self.path.display().to_string(),
                source: InferenceError::NotBuilt(kind),
            }),
        }
    }

    /// The default backend (tract) on `threads` threads.
    pub fn tract(&self, threads: usize) -> Result<Box<dyn Backend>, ModelError> {
        let proto = self.onnx_for(BackendKind::Tract)?.clone();
        let b = TractBackend::new(proto, self.classes.len(), threads).map_err(|source| {
            ModelError::Backend {
                path: self.path.display().to_string(),
                source,
            }
        })?;
        Ok(Box::new(b))
    }

    /// The ONNX Runtime backend on `threads` intra-op threads (cargo feature `onnxruntime`;
    /// `ORT_DYLIB_PATH` names the library, see [`crate::backend::onnxruntime`]).
    #[cfg(feature = "onnxruntime")]
    pub fn onnxruntime(&self, threads: usize) -> Result<Box<dyn Backend>, ModelError> {
        let bytes = onnx_graph::encode(self.onnx_for(BackendKind::OnnxRuntime)?);
        let b = crate::backend::onnxruntime::OrtBackend::new(&bytes, self.classes.len(), threads)
            .map_err(|source| ModelError::Backend {
            path: self.path.display().to_string(),
            source,
        })?;
        Ok(Box::new(b))
    }

    /// The torch backend on `threads` threads (cargo feature `torch`): the paper's network from
    /// the weights, or the TorchScript module.
    #[cfg(feature = "torch")]
    pub fn torch(&self, threads: usize) -> Result<Box<dyn Backend>, ModelError> {
        use crate::backend::torch::TorchBackend;
        let shown = self.path.display().to_string();
        let b = match (&self.graph, self.arch) {
            (Graph::TorchScript, _) => TorchBackend::from_script(
                &self.path,
                Some(self.classes.len()),
                self.input_size,
                threads,
            ),
            (Graph::Onnx(proto), Some(arch)) if self.source == Source::Weights => {
                TorchBackend::from_weights(arch, self.classes.len(), &initializers(proto), threads)
            }
            (Graph::Onnx(_), _) => return Err(ModelError::NotForTorch { path: shown }),
        }
        .map_err(|source| ModelError::Backend {
            path: shown,
            source,
        })?;
        Ok(Box::new(b))
    }

    /// The preprocessing this model's inputs get: the sensor's profile when given, else the
    /// reference geometry when asked for (or when the model card says the reference code's
    /// preprocessing trained it).
    pub fn preprocessing(
        &self,
        profile: Option<&Profile>,
        reference: Option<ReferenceSensor>,
    ) -> Result<Preprocessing, ModelError> {
        if let Some(r) = reference {
            return Ok(Preprocessing::reference(r, self.colour, self.input_size)?);
        }
        if let Some(p) = profile {
            return Ok(Preprocessing::from_profile(
                p,
                self.colour,
                self.input_size,
            )?);
        }
        let path = self.path.display().to_string();
        match self.card.as_ref().and_then(|c| c.preprocessing.as_deref()) {
            Some("reference-layered") => Ok(Preprocessing::reference(
                ReferenceSensor::Layered,
                self.colour,
                self.input_size,
            )?),
            Some("reference-integrated") => Ok(Preprocessing::reference(
                ReferenceSensor::Integrated,
                self.colour,
                self.input_size,
            )?),
            None | Some("profile") => Err(ModelError::NoGeometry { path }),
            Some(other) => Err(ModelError::CardPreprocessing {
                path,
                name: other.to_string(),
            }),
        }
    }

    /// The card a copy of this model carries: its own card with what inference needs (network,
    /// classes, input size, colour) as this model runs. A copy is of this network alone: a
    /// two-stage model's `force_model` names a file beside the original, so it is left out
    /// (`fringe model pair` joins a copy to its force network again).
    pub fn travelling_card(&self) -> ModelCard {
        let mut card = self.card.clone().unwrap_or_default();
        card.force_model = None;
        card.contact_model = None;
        if card.architecture.is_none() {
            card.architecture = self.arch.map(|a| a.name().to_string());
        }
        card.classes = Some(self.classes.clone());
        card.input_size = Some(self.input_size);
        card.colour = Some(self.colour);
        card
    }

    /// The ONNX graph with [`Model::travelling_card`] in its `metadata_props`, as `fringe model
    /// export` writes it.
    pub fn onnx_with_card(&self) -> Result<pb::ModelProto, ModelError> {
        let mut proto = self.onnx()?.clone();
        let text =
            serde_json::to_string(&self.travelling_card()).map_err(|e| ModelError::Onnx {
                path: self.path.display().to_string(),
                detail: format!("the model card cannot be written: {e}"),
            })?;
        proto.metadata_props.retain(|p| p.key != CARD_METADATA_KEY);
        proto.metadata_props.push(pb::StringStringEntryProto {
            key: CARD_METADATA_KEY.to_string(),
            value: text,
        });
        Ok(proto)
    }

    /// Refuses frames of another sensor design than the one the model's card names: `what`
    /// says whose design `variant` is ("this unit", "the data in runs/x"). A model without a
    /// card, or data whose design is not known, passes.
    pub fn check_design(&self, variant: Option<&str>, what: &str) -> Result<(), ModelError> {
        let design = self.card.as_ref().and_then(|c| c.variant.as_deref());
        match (design, variant) {
            (Some(design), Some(variant)) if design != variant => Err(ModelError::OtherDesign {
                path: self.path.display().to_string(),
                design: design.to_string(),
                variant: variant.to_string(),
                what: what.to_string(),
            }),
            _ => Ok(()),
        }
    }

    /// When the model has no card (none beside it, none in its metadata), what that means:
    /// input size, colour, classes and preprocessing are guesses, and wrong guesses give wrong
    /// figures without any error.
    pub fn missing_card_warning(&self) -> Option<String> {
        if self.card_source != CardSource::Missing {
            return None;
        }
        let [beside, _] = ModelCard::candidates(&self.path);
        Some(format!(
            "{}: no model card (none at {}, none in the file's metadata): running it as {} px {} \
             input, classes {}; if it was trained otherwise its figures are wrong, with no error. \
             Put its card beside it (fringe train writes one with every model)",
            self.path.display(),
            beside.display(),
            self.input_size,
            self.colour.name(),
            self.classes.join(", ")
        ))
    }

    /// When frames through `pre` show the sensor much coarser than the frames the model was
    /// trained on (its card's `crop_diameter_px`), what that means: the model sees less detail
    /// than it learnt from, and its figures do not hold, without any error.
    pub fn scale_warning(&self, pre: &Preprocessing) -> Option<String> {
        let card = self.card.as_ref()?;
        let trained = card.crop_diameter_px?;
        let now = 2.0 * pre.crop_radius_px;
        if now >= SCALE_TOLERANCE * trained {
            return None;
        }
        let frames = pre
            .frame_size
            .map(|(w, h)| format!(" in {w}x{h} frames"))
            .unwrap_or_default();
        let trained_frames = card
            .frame_size
            .map(|[w, h]| format!(" in {w}x{h} frames"))
            .unwrap_or_default();
        Some(format!(
            "{}: the sensor {} is {now:.0} px across{frames}, but the model was trained on \
             {trained:.0} px{trained_frames}: it would see {:.1}x less detail than it learnt \
             from and its figures do not hold; record at the scale it was trained on (for the \
             simulated bench, [sim] image_scale = 1) or train a model on such frames",
            self.path.display(),
            pre.sensor,
            trained / now
        ))
    }

    /// What the model is, in a few words ("custom CNN", "ONNX graph").
    pub fn describe(&self) -> String {
        let network = match (&self.arch, &self.source) {
            (Some(a), Source::Weights) => a.to_string(),
            (Some(a), Source::Onnx) => format!("{a} (ONNX graph)"),
            (_, Source::TorchScript) => "TorchScript module".to_string(),
            (None, _) => "ONNX graph".to_string(),
        };
        // A two-stage model: its window networks, in the order they run.
        let stages: Vec<String> = [
            (&self.contact_refiner, "placing the contact"),
            (&self.force, "reading the force"),
        ]
        .into_iter()
        .filter_map(|(net, does)| {
            let net = net.as_ref()?;
            let window = net
                .force_window_mm()
                .map_or(String::new(), |mm| format!(" on a {mm} mm window"));
            Some(format!("{}{window} {does}", net.describe()))
        })
        .collect();
        if stages.is_empty() {
            network
        } else {
            format!("{network}, then {}", stages.join(", then "))
        }
    }
}

/// An ONNX graph's f32 initialisers by name.
fn initializers(proto: &pb::ModelProto) -> StateDict {
    let mut sd = StateDict::new();
    for t in proto.graph.iter().flat_map(|g| &g.initializer) {
        if t.data_type != pb::tensor_proto::DataType::Float as i32 {
            continue;
        }
        let data: Vec<f32> = if t.raw_data.is_empty() {
            t.float_data.clone()
        } else {
            t.raw_data
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect()
        };
        let shape = t.dims.iter().map(|&d| d.max(0) as usize).collect();
        if let Some(tensor) = Tensor::new(shape, data) {
            sd.insert(&t.name, tensor);
        }
    }
    sd
}

/// The height and width a graph's image input declares ([N, 3, H, W], H and W fixed), when it
/// does (fringe's own graphs take any size; `torch.onnx.export` fixes the size it was given).
fn declared_input(proto: &pb::ModelProto) -> Option<[u32; 2]> {
    use pb::tensor_shape_proto::dimension::Value;
    let graph = proto.graph.as_ref()?;
    // Older exporters list the weights among the inputs too.
    let weights: std::collections::HashSet<&str> =
        graph.initializer.iter().map(|t| t.name.as_str()).collect();
    let input = graph
        .input
        .iter()
        .find(|i| !weights.contains(i.name.as_str()))?;
    let pb::type_proto::Value::TensorType(t) = input.r#type.as_ref()?.value.as_ref()?;
    let dims = &t.shape.as_ref()?.dim;
    if dims.len() != 4 {
        return None;
    }
    let side = |k: usize| match dims[k].value.as_ref()? {
        Value::DimValue(v) if *v > 0 => u32::try_from(*v).ok(),
        _ => None,
    };
    Some([side(2)?, side(3)?])
}

/// The fixed width of the shape-logits output, when the graph states it.
fn logits_width(proto: &pb::ModelProto) -> Option<usize> {
    use pb::tensor_shape_proto::dimension::Value;
    let order = output_order(proto).ok()?;
    let out = proto.graph.as_ref()?.output.get(order[1])?;
    let pb::type_proto::Value::TensorType(t) = out.r#type.as_ref()?.value.as_ref()?;
    match t.shape.as_ref()?.dim.get(1)?.value.as_ref()? {
        Value::DimValue(v) if *v > 0 => Some(*v as usize),
        _ => None,
    }
}
