//! The models that ship inside fringe, so that `fringe model`, `fringe eval` and live validation
//! work on a fresh clone with nothing to download: networks trained by `fringe train` on frames
//! of `fringe sim dataset`, one per simulated sensor design, with their cards
//! (`sensor-models/models/`, README.md "The default models" gives the commands that made them).
//!
//! A model is named where a model file is expected: `default` (`builtin:layered`, the layered
//! design's one-network custom CNN) or `builtin:NAME`. A sensor of a known design gets its
//! design's two-stage model ([`for_design`]). [`open`] is the one place that resolves a name or a path.

use crate::model::{Model, ModelError};
use crate::model_card::{CardSource, ModelCard};
use crate::weights::safetensors_file::read_safetensors_bytes;
use std::path::{Path, PathBuf};

/// A model compiled into the binary.
pub struct Builtin {
    /// Its name after `builtin:`.
    pub name: &'static str,
    /// What it is for, in a few words.
    pub about: &'static str,
    /// The sensor design it is for (its card's `variant`).
    pub design: &'static str,
    /// The model eval, validate and the UI take for a sensor of its design not commissioned (one
    /// per design): its most accurate that runs at the camera's rate.
    pub chosen_for_design: bool,
    /// The model `fringe commission` adapts to a unit of its design (one per design).
    pub commissioning_base: bool,
    /// A window network of a two-stage model (its force or contact network): run only through
    /// the built-in model whose card names it, never chosen for a design.
    pub window_network: bool,
    weights: &'static [u8],
    card: &'static str,
}

/// The models that ship; the first is `default`.
pub const BUILTIN: &[Builtin] = &[
    Builtin {
        name: "layered",
        about: "custom CNN for the simulated layered sensor (trained on fringe sim dataset frames)",
        design: "layered",
        chosen_for_design: false,
        commissioning_base: false,
        window_network: false,
        weights: include_bytes!("../models/layered-custom.safetensors"),
        card: include_str!("../models/layered-custom.json"),
    },
    Builtin {
        name: "layered-keypoint",
        about: "keypoint CNN for the simulated layered sensor: the base commissioning adapts to a \
                layered unit (its features keep where the contact is)",
        design: "layered",
        chosen_for_design: false,
        commissioning_base: true,
        window_network: false,
        weights: include_bytes!("../models/layered-keypoint.safetensors"),
        card: include_str!("../models/layered-keypoint.json"),
    },
    Builtin {
        name: "layered-two-stage",
        about: "two-stage model for the simulated layered sensor: the keypoint CNN finds the \
                contact and the shape, builtin:layered-contact places the contact in a 24 mm \
                window about it, builtin:layered-force reads the force in a 24 mm window about \
                that",
        design: "layered",
        chosen_for_design: true,
        commissioning_base: false,
        window_network: false,
        // The first network is the keypoint CNN above, its weights shared; the card differs.
        weights: include_bytes!("../models/layered-keypoint.safetensors"),
        card: include_str!("../models/layered-two-stage.json"),
    },
    Builtin {
        name: "layered-contact",
        about: "the contact network of builtin:layered-two-stage (a keypoint CNN on a 24 mm \
                window about the contact, reading where the press lies in it): not run alone",
        design: "layered",
        chosen_for_design: false,
        commissioning_base: false,
        window_network: true,
        weights: include_bytes!("../models/layered-contact.safetensors"),
        card: include_str!("../models/layered-contact.json"),
    },
    Builtin {
        name: "layered-force",
        about: "the force network of builtin:layered-two-stage (a custom CNN on a 24 mm window \
                about the contact): not run alone",
        design: "layered",
        chosen_for_design: false,
        commissioning_base: false,
        window_network: true,
        weights: include_bytes!("../models/layered-force.safetensors"),
        card: include_str!("../models/layered-force.json"),
    },
    Builtin {
        name: "integrated",
        about: "keypoint CNN for the simulated integrated sensor (trained on fringe sim dataset \
                frames)",
        design: "integrated",
        chosen_for_design: false,
        commissioning_base: true,
        window_network: false,
        weights: include_bytes!("../models/integrated-keypoint.safetensors"),
        card: include_str!("../models/integrated-keypoint.json"),
    },
    Builtin {
        name: "integrated-two-stage",
        about: "two-stage model for the simulated integrated sensor: the keypoint CNN finds the \
                contact, the shape and the force on the whole disc, builtin:integrated-contact \
                places the contact in a 24 mm window about it",
        design: "integrated",
        chosen_for_design: true,
        commissioning_base: false,
        window_network: false,
        // The first network is builtin:integrated, its weights shared; the card differs.
        weights: include_bytes!("../models/integrated-keypoint.safetensors"),
        card: include_str!("../models/integrated-two-stage.json"),
    },
    Builtin {
        name: "integrated-contact",
        about: "the contact network of builtin:integrated-two-stage (a keypoint CNN on a 24 mm \
                window about the contact, reading where the press lies in it): not run alone",
        design: "integrated",
        chosen_for_design: false,
        commissioning_base: false,
        window_network: true,
        weights: include_bytes!("../models/integrated-contact.safetensors"),
        card: include_str!("../models/integrated-contact.json"),
    },
];

/// The name that stands for the first built-in model.
pub const DEFAULT: &str = "default";

/// The built-in model a model argument names, if it names one: `default` or `builtin:NAME`.
/// A path to an existing file named `default` is still that file when written as `./default`.
pub fn named(spec: &Path) -> Option<Result<&'static Builtin, ModelError>> {
    let s = spec.to_str()?;
    if s == DEFAULT {
        return BUILTIN.first().map(Ok);
    }
    let name = s.strip_prefix("builtin:")?;
    Some(
        BUILTIN
            .iter()
            .find(|b| b.name == name)
            .ok_or_else(|| ModelError::UnknownBuiltin {
                name: name.to_string(),
                known: listed(|b| b.name),
            }),
    )
}

impl Builtin {
    /// The path a built-in model shows in messages and reports.
    pub fn path(&self) -> PathBuf {
        PathBuf::from(format!("builtin:{}", self.name))
    }

    /// Its weights file's bytes, as shipped (what a certificate hashes).
    pub fn weights_bytes(&self) -> &'static [u8] {
        self.weights
    }

    /// Its card, as shipped (checked as every card is).
    pub fn card(&self) -> Result<ModelCard, ModelError> {
        Ok(ModelCard::parse(
            &format!("{} (card)", self.path().display()),
            self.card,
        )?)
    }

    /// The model, ready to run.
    pub fn model(&self) -> Result<Model, ModelError> {
        let path = self.path();
        let sd = read_safetensors_bytes(self.weights, &path.display().to_string())?;
        Model::from_weights(&path, sd, Some(self.card()?), CardSource::Builtin)
    }
}

/// The model that ships for a sensor design (the one [`Builtin::chosen_for_design`]), as a model
/// argument (`builtin:NAME`); `default` when the design is not known. A design no model ships
/// for is refused, naming those that do.
pub fn for_design(design: Option<&str>) -> Result<PathBuf, ModelError> {
    let Some(design) = design else {
        return Ok(PathBuf::from(DEFAULT));
    };
    BUILTIN
        .iter()
        .find(|b| b.design == design && b.chosen_for_design)
        .map(Builtin::path)
        .ok_or_else(|| ModelError::NoneShipped {
            design: design.to_string(),
            known: listed(|b| b.design),
        })
}

/// The model `fringe commission` adapts to a unit of `design` when no base is given, as a model
/// argument: the built-in model marked as its design's commissioning base (that of `default`'s
/// design when the design is not known). A design no model ships for is refused.
pub fn commissioning_base(design: Option<&str>) -> Result<PathBuf, ModelError> {
    let design = design
        .or(BUILTIN.first().map(|b| b.design))
        .unwrap_or_default();
    BUILTIN
        .iter()
        .find(|b| b.design == design && b.commissioning_base)
        .map(Builtin::path)
        .ok_or_else(|| ModelError::NoneShipped {
            design: design.to_string(),
            known: listed(|b| b.design),
        })
}

/// What every built-in model has of `what`, listed for a message.
fn listed(what: impl Fn(&Builtin) -> &'static str) -> String {
    let mut seen: Vec<&str> = Vec::new();
    for b in BUILTIN {
        let w = what(b);
        if !seen.contains(&w) {
            seen.push(w);
        }
    }
    seen.join(", ")
}

/// A model argument: a built-in model's name (`default`, `builtin:NAME`) or a model file; a
/// two-stage model with its window networks (its card's `force_model` and `contact_model`:
/// `builtin:NAME`, or a file beside the model) attached.
pub fn open(spec: &Path) -> Result<Model, ModelError> {
    let mut model = match named(spec) {
        Some(b) => b?.model()?,
        None => Model::open(spec)?,
    };
    let card = model.card.clone().unwrap_or_default();
    if let Some(name) = &card.force_model {
        model.force = Some(Box::new(window_network(&model, name)?));
    }
    if let Some(name) = &card.contact_model {
        let net = window_network(&model, name)?;
        if !net.card.as_ref().is_some_and(|c| c.refines_contact) {
            return Err(ModelError::NotAContactNetwork {
                path: net.path.display().to_string(),
                of: model.path.display().to_string(),
            });
        }
        model.contact_refiner = Some(Box::new(net));
    }
    Ok(model)
}

/// The window network `name` of the two-stage model `model`: a built-in one or a file beside the
/// model, trained on a window about the contact (`fringe train --force-window`), of the model's
/// sensor design.
fn window_network(model: &Model, name: &str) -> Result<Model, ModelError> {
    let named_path = Path::new(name);
    let net = match named(named_path) {
        Some(b) => b?.model()?,
        None => {
            let beside = match model.path.parent() {
                Some(dir) => dir.join(named_path),
                None => named_path.to_path_buf(),
            };
            Model::open(&beside)?
        }
    };
    let of = model.path.display().to_string();
    if net.force_window_mm().is_none() || net.force.is_some() || net.contact_refiner.is_some() {
        return Err(ModelError::NotAWindowNetwork {
            path: net.path.display().to_string(),
            of,
        });
    }
    // Every network reads one sensor design.
    let design = model.card.as_ref().and_then(|c| c.variant.clone());
    net.check_design(design.as_deref(), &format!("the two-stage model {of}"))?;
    Ok(net)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arch::Architecture;

    #[test]
    fn every_builtin_model_opens_with_its_card_and_is_small() {
        for b in BUILTIN {
            let m = b.model().expect("built-in model opens");
            let arch = m.card.as_ref().and_then(|c| c.architecture.as_deref());
            assert_eq!(m.arch.map(Architecture::name), arch, "{}", b.name);
            assert_eq!(m.classes, ["None", "pentagon", "rectangle"], "{}", b.name);
            assert!(b.weights.len() < 1 << 20, "{} weights over 1 MB", b.name);
            assert!(b.card.len() < 1 << 20, "{} card over 1 MB", b.name);
            assert_eq!(
                m.card.as_ref().and_then(|c| c.preprocessing.as_deref()),
                Some("profile")
            );
            assert_eq!(
                m.card.as_ref().and_then(|c| c.variant.as_deref()),
                Some(b.design),
                "{}",
                b.name
            );
            let shipped = for_design(Some(b.design)).expect("a model ships for its design");
            let chosen: Vec<_> = BUILTIN
                .iter()
                .filter(|o| o.design == b.design && o.chosen_for_design)
                .collect();
            assert_eq!(chosen.len(), 1, "one model chosen for {}", b.design);
            assert_eq!(shipped, chosen[0].path(), "{}", b.design);
            assert!(!chosen[0].window_network, "{}", b.design);
            let bases = BUILTIN
                .iter()
                .filter(|o| o.design == b.design && o.commissioning_base)
                .count();
            assert_eq!(bases, 1, "one commissioning base for {}", b.design);
        }
    }

    /// The two-stage model opens with its built-in window networks attached; a window network
    /// is never what a design gets, and alone it is refused, saying how to run it.
    #[test]
    fn the_two_stage_model_brings_its_window_networks_which_are_never_run_alone() {
        let two = open(Path::new("builtin:layered-two-stage")).expect("opens");
        assert_eq!(two.arch.map(Architecture::name), Some("keypoint"));
        let force = two.force.as_ref().expect("its force network attached");
        assert_eq!(force.path, Path::new("builtin:layered-force"));
        assert_eq!(force.force_window_mm(), Some(24.0));
        let contact = two
            .contact_refiner
            .as_ref()
            .expect("its contact network attached");
        assert_eq!(contact.path, Path::new("builtin:layered-contact"));
        assert!(contact.card.as_ref().is_some_and(|c| c.refines_contact));
        assert_eq!(contact.arch.map(Architecture::name), Some("keypoint"));
        // The integrated design's keeps the whole disc's force: a contact network alone.
        let two = open(Path::new("builtin:integrated-two-stage")).expect("opens");
        assert!(two.force.is_none());
        let contact = two.contact_refiner.as_ref().expect("its contact network");
        assert_eq!(contact.path, Path::new("builtin:integrated-contact"));
        assert_eq!(
            contact.card.as_ref().and_then(|c| c.variant.as_deref()),
            Some("integrated")
        );
        // What eval, validate and the UI name it: each network, in the order they run.
        assert_eq!(
            two.describe(),
            "keypoint CNN, then keypoint CNN on a 24 mm window placing the contact"
        );
        for b in BUILTIN.iter().filter(|b| b.window_network) {
            assert_ne!(
                for_design(Some(b.design)).ok(),
                Some(b.path()),
                "{}",
                b.name
            );
            let alone = open(&b.path()).expect("opens as a file would");
            let e = crate::predictor::Predictor::new(&alone, crate::backend::BackendKind::Tract, 1)
                .err()
                .expect("refused alone");
            assert!(e.to_string().contains("fringe model pair"), "{e}");
        }
    }

    /// Commissioning adapts the keypoint CNN on both designs (the custom CNN's pooled features
    /// do not carry where another unit's contact is), while eval and validate take each design's
    /// two-stage model for units not commissioned.
    #[test]
    fn commissioning_adapts_each_design_s_base_and_eval_takes_its_two_stage_model() {
        let base = |d| commissioning_base(d).ok().map(|p| p.display().to_string());
        assert_eq!(
            base(Some("layered")).as_deref(),
            Some("builtin:layered-keypoint")
        );
        assert_eq!(base(None).as_deref(), Some("builtin:layered-keypoint"));
        assert_eq!(
            base(Some("integrated")).as_deref(),
            Some("builtin:integrated")
        );
        assert_eq!(
            for_design(Some("layered")).ok(),
            Some(PathBuf::from("builtin:layered-two-stage"))
        );
        let b = open(Path::new("builtin:layered-keypoint")).expect("opens");
        assert_eq!(b.arch.map(Architecture::name), Some("keypoint"));
        let e = commissioning_base(Some("thick")).expect_err("nothing ships for it");
        assert!(e.to_string().contains("layered, integrated"), "{e}");
    }

    /// The default model was trained on 1920x1200 frames where the sensor is 980 px across:
    /// frames a quarter that size (`[sim] image_scale = 0.25`) are warned about, naming both.
    #[test]
    fn frames_coarser_than_the_training_frames_are_warned_about() {
        use crate::preprocess::{Centre, Colour, Preprocessing};
        let m = open(Path::new("default")).expect("default");
        let at = |radius: f64, w: u32, h: u32| Preprocessing {
            centre: Centre::Image,
            crop_radius_px: radius,
            frame_size: Some((w, h)),
            sensor: "layered-1".into(),
            input_size: 112,
            colour: Colour::Grey,
            reference: false,
        };
        assert_eq!(m.scale_warning(&at(490.0, 1920, 1200)), None);
        assert_eq!(m.scale_warning(&at(400.0, 1920, 1200)), None);
        let w = m
            .scale_warning(&at(122.5, 480, 300))
            .expect("a quarter-size frame is warned about");
        assert!(
            w.contains("245 px across in 480x300 frames")
                && w.contains("980 px in 1920x1200 frames")
                && w.contains("4.0x less detail"),
            "{w}"
        );
    }

    #[test]
    fn a_design_nothing_ships_for_is_refused_naming_those_that_ship() {
        assert_eq!(
            for_design(Some("integrated")).ok(),
            Some(PathBuf::from("builtin:integrated-two-stage"))
        );
        assert_eq!(for_design(None).ok(), Some(PathBuf::from(DEFAULT)));
        let e = for_design(Some("thick")).expect_err("nothing ships for it");
        let msg = e.to_string();
        assert!(
            msg.contains("no model ships for the thick sensor design")
                && msg.contains("layered, integrated")
                && msg.contains("--model"),
            "{msg}"
        );
    }

    #[test]
    fn names_resolve_and_unknown_names_list_the_known_ones() {
        let d = open(Path::new("default")).expect("default");
        assert_eq!(d.path, Path::new("builtin:layered"));
        assert!(open(Path::new("builtin:layered")).is_ok());
        let e = open(Path::new("builtin:nope")).expect_err("unknown");
        let msg = e.to_string();
        assert!(msg.contains("nope") && msg.contains("layered"), "{msg}");
        // Anything else is a path.
        let e = open(Path::new("./default")).expect_err("no such file");
        assert!(e.to_string().contains("./default"), "{e}");
    }
}
