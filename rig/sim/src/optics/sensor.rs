//! One simulated sensor build: its photoelastic layer, optics, camera artefacts and the geometry
//! that maps the sensor frame (mm) to image pixels.
//!
//! A configuration file is TOML. Every key is optional: `variant` picks the defaults
//! ([`SensorConfig::layered`] or [`SensorConfig::integrated`]) and the file overrides single keys;
//! unknown keys are refused with the list of allowed ones. Example files: `rig/sim/sensors/*.toml`.
//!
//! Defaults follow docs/photoelastic-sim.md ("Camera artefacts", "Geometry of the reference rig").

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

use crate::bench::IndenterTip;
use crate::optics::scratch::Scratch;
use crate::physics::friction::Friction;
use crate::physics::indenter::Shape;
use crate::physics::stress::Layer;

/// Which of the two sensor builds of the reference paper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Variant {
    /// Sensor 1: a 1 mm photoelastic film on polyurethane at the contact side; few fringes that hug
    /// the indenter outline.
    Layered,
    /// Sensor 2: a 20 mm photoelastic gel; many broad fringes fading to high-order white.
    Integrated,
}

impl Variant {
    /// Lower-case name as in the configuration file.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Layered => "layered",
            Variant::Integrated => "integrated",
        }
    }
}

/// The photoelastic layer and the material fringe value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayerConfig {
    /// Depth of the top of the photoelastic layer below the contact surface, mm (default 0).
    pub top_mm: f64,
    /// Depth of its bottom, mm (default 1 layered, 20 integrated).
    pub bottom_mm: f64,
    /// Poisson's ratio of the gel (default 0.49).
    pub nu: f64,
    /// Material fringe value f_sigma, N/m per fringe (default 28 layered, 70 integrated). Ignored
    /// when `target_fringes` is above 0.
    pub f_sigma_n_per_m: f64,
    /// When above 0: choose f_sigma so that the rectangle at `target_force_n` reaches this largest
    /// fringe order (docs/photoelastic-sim.md, "Optics"). Default 0 (use `f_sigma_n_per_m`).
    pub target_fringes: f64,
    /// Force of the `target_fringes` calibration, N (default 9).
    pub target_force_n: f64,
    /// Effective modulus E* of the gel for the sphere's Hertz contact, MPa (default 0.66).
    pub effective_modulus_mpa: f64,
}

/// Focus, illumination and polariser.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpticsConfig {
    /// Defocus: pillbox radius in px, about a Gaussian of sigma = blur / 2. 0 = sharp, 4-10 =
    /// blurred (default 0 layered, 3 integrated).
    pub blur_px: f64,
    /// Light that passes a fully bright fringe at the disc centre, DN (default 210).
    pub illumination_dn: f64,
    /// Vignetting V = (1 + (r / f)^2)^-2 with f = this factor times the disc radius (default 3).
    pub vignetting_factor: f64,
    /// Brightening towards the rim inside the disc: gain 1 + rim_shading (r / R)^6 (default 0.25).
    pub rim_shading: f64,
    /// Bright scattering ring at the disc edge (after the polariser), peak DN (default 25).
    pub rim_glow_dn: f64,
    /// Width (Gaussian sigma) of the rim ring, px (default 5).
    pub rim_width_px: f64,
    /// Light outside the disc (housing), DN (default 4).
    pub ambient_dn: f64,
    /// Wavelength at which the polariser's film plate is exactly quarter-wave, nm: it leaks the
    /// faint bluish unloaded background. 0 = ideal plate, black background (default 560).
    pub quarter_wave_nm: f64,
    /// Residual casting birefringence: mean fringe order of a smooth field (0.05-0.2, default 0.12
    /// layered, 0.15 integrated). 0 turns it off.
    pub residual_birefringence: f64,
    /// Output gamma: 8-bit value = 255 (I / 255)^(1 / gamma) (default 1, a machine-vision camera).
    pub gamma: f64,
}

/// Where the sensor disc lands in the image.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeometryConfig {
    /// Image width, px (default 1920).
    pub width: u32,
    /// Image height, px (default 1200).
    pub height: u32,
    /// Sensor disc radius in the image, px (default 490 layered, 550 integrated).
    pub disc_radius_px: f64,
    /// Image scale, px per mm (default 18.3).
    pub px_per_mm: f64,
    /// Optical centre (image of the sensor frame's origin) relative to the image centre, px,
    /// [x right, y down] (default [30, 0] layered, [28, -6] integrated).
    pub centre_offset_px: [f64; 2],
    /// Rotation of the image relative to the stage axes, degrees counter-clockwise on the image
    /// (default 0 layered, 90 integrated).
    pub rotation_deg: f64,
    /// The view from below is mirror-reversed: flips the sensor frame's x before rotation
    /// (default true).
    pub mirror: bool,
}

/// The LED ring's hot spots, reflected at the rim after the polariser.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LedConfig {
    /// Number of LEDs (default 12; 0 = none).
    pub count: u32,
    /// Radius of the hot spots relative to the disc radius (default 1.02).
    pub radius_factor: f64,
    /// Full width at half maximum of a hot spot, px (default 30).
    pub width_px: f64,
    /// Peak added brightness, DN (default 150).
    pub strength_dn: f64,
    /// Angle of the first LED in the sensor frame, degrees (default 7.5).
    pub phase_deg: f64,
    /// LEDs that failed, by 0-based index in ring order from `phase_deg` (default none): their
    /// hot spot is gone and the disc's illumination loses their share, most on their side
    /// (docs/photoelastic-sim.md, "Ageing of a unit").
    #[serde(default)]
    pub out: Vec<u32>,
}

/// The contact surface: its friction against the indenters and its flaws.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SurfaceFinish {
    /// Grooves on the contact surface (default none; `[[surface.scratches]]`, see
    /// [`crate::optics::scratch`]).
    #[serde(default)]
    pub scratches: Vec<Scratch>,
    /// Static friction coefficient against the indenters (default 1.0): an indenter pushed
    /// along the surface starts sliding at this many times its normal force.
    #[serde(default = "default_friction_static")]
    pub friction_static: f64,
    /// Kinetic friction coefficient (default 0.8, at most `friction_static`): a sliding
    /// indenter carries this many times its normal force.
    #[serde(default = "default_friction_kinetic")]
    pub friction_kinetic: f64,
}

fn default_friction_static() -> f64 {
    Friction::default().static_coefficient
}

fn default_friction_kinetic() -> f64 {
    Friction::default().kinetic_coefficient
}

impl Default for SurfaceFinish {
    fn default() -> Self {
        SurfaceFinish {
            scratches: Vec::new(),
            friction_static: default_friction_static(),
            friction_kinetic: default_friction_kinetic(),
        }
    }
}

impl SurfaceFinish {
    /// The friction these keys give.
    pub fn friction(&self) -> Friction {
        Friction {
            static_coefficient: self.friction_static,
            kinetic_coefficient: self.friction_kinetic,
        }
    }
}

/// Sensor noise, brightness drift and LED flicker.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseConfig {
    /// Poisson part a of the variance a I + b (DN per DN, default 0.05).
    pub poisson_a: f64,
    /// Gaussian part b of the variance a I + b (DN^2, default 2.25: sigma 1.5 DN in the dark,
    /// 3.5 DN at 200 DN).
    pub gaussian_b: f64,
    /// Amplitude of the slow gain drift, fraction (default 0.05: gain within 0.95-1.05).
    pub gain_drift: f64,
    /// Amplitude of the slow offset drift, DN (default 3).
    pub offset_drift_dn: f64,
    /// Frame-to-frame LED flicker, standard deviation as a fraction (default 0.01).
    pub flicker: f64,
}

/// Radius of the simulated bench's circular punch, mm (no sensor definition names a circle).
pub(crate) const CIRCLE_RADIUS_MM: f64 = 4.0;

/// Indenter sizes for the shape names of `fringe sim render --shape`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IndenterConfig {
    /// Pentagon circumradius (centre to vertex), mm (default 5).
    pub pentagon_circumradius_mm: f64,
    /// Rectangle width along the indenter's x, mm (default 10).
    pub rectangle_width_mm: f64,
    /// Rectangle height, mm (default 6).
    pub rectangle_height_mm: f64,
    /// Sphere radius, mm (default 5).
    pub sphere_radius_mm: f64,
}

/// Grid of the precomputed fringe fields.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FieldConfig {
    /// Cells per side (default 384).
    pub cells: usize,
    /// Cell side, mm (default 0.25: the grid spans 96 mm, beyond the 60 mm disc's diameter).
    pub cell_mm: f64,
}

/// One sensor build. See the module documentation for the file format.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorConfig {
    /// Free-form identifier (default "layered-1" / "integrated-1").
    pub id: String,
    /// Which build the defaults come from (default layered).
    pub variant: Variant,
    /// Seed of every random element: residual birefringence, noise, drift (default 1).
    pub seed: u64,
    /// Worker threads per frame (default 2).
    pub threads: usize,
    pub layer: LayerConfig,
    pub optics: OpticsConfig,
    pub geometry: GeometryConfig,
    pub leds: LedConfig,
    pub noise: NoiseConfig,
    pub indenters: IndenterConfig,
    pub field: FieldConfig,
    /// Scratches on the contact surface (default none).
    #[serde(default)]
    pub surface: SurfaceFinish,
}

/// A sensor configuration that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum SensorConfigError {
    #[error("cannot read sensor configuration {path}: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("sensor configuration {path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("sensor configuration {source_name}: key `{key}` = {value}: {allowed}")]
    Invalid {
        source_name: String,
        key: String,
        value: String,
        allowed: &'static str,
    },
}

impl SensorConfig {
    /// The simulated units that ship with fringe, by id: each design's reference build
    /// (`layered-1`, `integrated-1`: the builds `layered` and `integrated`) and the other units of
    /// each design (`rig/sim/sensors/<id>.toml`, built into the binary), so a unit is had by its
    /// id alone.
    pub const UNITS: [&'static str; 6] = [
        "layered-1",
        "layered-2",
        "layered-3",
        "integrated-1",
        "integrated-2",
        "integrated-3",
    ];

    /// The simulated unit `id` (one of [`SensorConfig::UNITS`]), or `None` for an id that is none of them.
    pub fn unit(id: &str) -> Option<SensorConfig> {
        let text = match id {
            "layered-1" => return Some(SensorConfig::layered()),
            "integrated-1" => return Some(SensorConfig::integrated()),
            "layered-2" => include_str!("../../sensors/layered-2.toml"),
            "layered-3" => include_str!("../../sensors/layered-3.toml"),
            "integrated-2" => include_str!("../../sensors/integrated-2.toml"),
            "integrated-3" => include_str!("../../sensors/integrated-3.toml"),
            _ => return None,
        };
        // The files are the ones the tests load from rig/sim/sensors/: they parse.
        SensorConfig::from_toml_str(text, &format!("built-in unit {id}")).ok()
    }

    /// Sensor 1: 1 mm film at the contact side, sharp, few fringes.
    pub fn layered() -> SensorConfig {
        SensorConfig {
            id: "layered-1".into(),
            variant: Variant::Layered,
            seed: 1,
            threads: 2,
            layer: LayerConfig {
                top_mm: 0.0,
                bottom_mm: 1.0,
                nu: 0.49,
                f_sigma_n_per_m: 28.0,
                target_fringes: 0.0,
                target_force_n: 9.0,
                effective_modulus_mpa: 0.66,
            },
            optics: OpticsConfig {
                blur_px: 0.0,
                illumination_dn: 210.0,
                vignetting_factor: 3.0,
                rim_shading: 0.25,
                rim_glow_dn: 25.0,
                rim_width_px: 5.0,
                ambient_dn: 4.0,
                quarter_wave_nm: 560.0,
                residual_birefringence: 0.12,
                gamma: 1.0,
            },
            geometry: GeometryConfig {
                width: 1920,
                height: 1200,
                disc_radius_px: 490.0,
                px_per_mm: 18.3,
                centre_offset_px: [30.0, 0.0],
                rotation_deg: 0.0,
                mirror: true,
            },
            leds: LedConfig {
                count: 12,
                radius_factor: 1.02,
                width_px: 30.0,
                strength_dn: 150.0,
                phase_deg: 7.5,
                out: Vec::new(),
            },
            noise: NoiseConfig {
                poisson_a: 0.05,
                gaussian_b: 2.25,
                gain_drift: 0.05,
                offset_drift_dn: 3.0,
                flicker: 0.01,
            },
            indenters: IndenterConfig {
                pentagon_circumradius_mm: 5.0,
                rectangle_width_mm: 10.0,
                rectangle_height_mm: 6.0,
                sphere_radius_mm: 5.0,
            },
            field: FieldConfig {
                cells: 384,
                cell_mm: 0.25,
            },
            surface: SurfaceFinish::default(),
        }
    }

    /// Sensor 2: 20 mm photoelastic gel, slightly defocused, many fringes.
    pub fn integrated() -> SensorConfig {
        let mut c = SensorConfig::layered();
        c.id = "integrated-1".into();
        c.variant = Variant::Integrated;
        c.layer.bottom_mm = 20.0;
        c.layer.f_sigma_n_per_m = 70.0;
        c.optics.blur_px = 3.0;
        c.optics.residual_birefringence = 0.15;
        c.geometry.disc_radius_px = 550.0;
        c.geometry.centre_offset_px = [28.0, -6.0];
        c.geometry.rotation_deg = 90.0;
        c.leds.count = 16;
        c.leds.phase_deg = 0.0;
        c
    }

    /// The defaults of `variant`.
    pub fn for_variant(variant: Variant) -> SensorConfig {
        match variant {
            Variant::Layered => SensorConfig::layered(),
            Variant::Integrated => SensorConfig::integrated(),
        }
    }

    /// Reads a TOML file: `variant` picks the defaults, every other key overrides one of them.
    pub fn load(path: &Path) -> Result<SensorConfig, SensorConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| SensorConfigError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        SensorConfig::from_toml_str(&text, &path.display().to_string())
    }

    /// Parses TOML text; `source_name` (a file name) goes into error messages.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<SensorConfig, SensorConfigError> {
        let parse_error = |message: String| SensorConfigError::Parse {
            path: PathBuf::from(source_name),
            message: message.trim().replace('\n', " "),
        };
        let file: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| parse_error(e.to_string()))?;
        let variant = match file.get("variant") {
            None => Variant::Layered,
            Some(toml::Value::String(s)) if s == "layered" => Variant::Layered,
            Some(toml::Value::String(s)) if s == "integrated" => Variant::Integrated,
            Some(other) => {
                return Err(SensorConfigError::Invalid {
                    source_name: source_name.into(),
                    key: "variant".into(),
                    value: other.to_string(),
                    allowed: "allowed: \"layered\" or \"integrated\"",
                })
            }
        };
        let defaults = toml::Table::try_from(SensorConfig::for_variant(variant))
            .map_err(|e| parse_error(e.to_string()))?;
        let merged = merge(defaults, file);
        let config: SensorConfig = merged
            .try_into()
            .map_err(|e: toml::de::Error| parse_error(e.to_string()))?;
        config.validate(source_name)?;
        Ok(config)
    }

    /// Checks every value the renderer relies on; `source_name` goes into the error.
    pub fn validate(&self, source_name: &str) -> Result<(), SensorConfigError> {
        self.check_layer()
            .and_then(|()| self.check_non_negative())
            .and_then(|()| self.check_positive())
            .and_then(|()| self.check_sizes())
            .and_then(|()| self.check_flaws())
            .map_err(|bad| SensorConfigError::Invalid {
                source_name: source_name.into(),
                key: bad.key,
                value: bad.value,
                allowed: bad.allowed,
            })
    }

    /// The photoelastic layer's values.
    fn check_layer(&self) -> Result<(), Bad> {
        let l = &self.layer;
        if !(finite(l.top_mm) && l.top_mm >= 0.0) {
            return bad("layer.top_mm", l.top_mm.to_string(), "must be >= 0");
        }
        if !(finite(l.bottom_mm) && l.bottom_mm > l.top_mm) {
            return bad(
                "layer.bottom_mm",
                l.bottom_mm.to_string(),
                "must exceed layer.top_mm",
            );
        }
        if !(finite(l.nu) && l.nu > 0.0 && l.nu <= 0.5) {
            return bad("layer.nu", l.nu.to_string(), "must be in (0, 0.5]");
        }
        if !(finite(l.f_sigma_n_per_m) && l.f_sigma_n_per_m > 0.0) {
            return bad(
                "layer.f_sigma_n_per_m",
                l.f_sigma_n_per_m.to_string(),
                "must be > 0",
            );
        }
        if !(finite(l.target_fringes) && l.target_fringes >= 0.0 && l.target_fringes <= 20.0) {
            return bad(
                "layer.target_fringes",
                l.target_fringes.to_string(),
                "must be in 0..=20 (0 = use f_sigma)",
            );
        }
        if !(finite(l.target_force_n) && l.target_force_n > 0.0) {
            return bad(
                "layer.target_force_n",
                l.target_force_n.to_string(),
                "must be > 0",
            );
        }
        if !(finite(l.effective_modulus_mpa) && l.effective_modulus_mpa > 0.0) {
            return bad(
                "layer.effective_modulus_mpa",
                l.effective_modulus_mpa.to_string(),
                "must be > 0",
            );
        }
        Ok(())
    }

    /// The blur's range, and the optics', LEDs' and noise's values that may be 0 but not less.
    fn check_non_negative(&self) -> Result<(), Bad> {
        let o = &self.optics;
        if !(finite(o.blur_px) && (0.0..=40.0).contains(&o.blur_px)) {
            return bad(
                "optics.blur_px",
                o.blur_px.to_string(),
                "must be in 0..=40 px",
            );
        }
        for (key, v) in [
            ("optics.illumination_dn", o.illumination_dn),
            ("optics.rim_shading", o.rim_shading),
            ("optics.rim_glow_dn", o.rim_glow_dn),
            ("optics.ambient_dn", o.ambient_dn),
            ("optics.residual_birefringence", o.residual_birefringence),
            ("optics.quarter_wave_nm", o.quarter_wave_nm),
            ("leds.strength_dn", self.leds.strength_dn),
            ("noise.poisson_a", self.noise.poisson_a),
            ("noise.gaussian_b", self.noise.gaussian_b),
            ("noise.gain_drift", self.noise.gain_drift),
            ("noise.offset_drift_dn", self.noise.offset_drift_dn),
            ("noise.flicker", self.noise.flicker),
        ] {
            if !(finite(v) && v >= 0.0) {
                return bad(key, v.to_string(), "must be a number >= 0");
            }
        }
        Ok(())
    }

    /// The values that must be more than 0 (scales, radii, widths, sizes of cells).
    fn check_positive(&self) -> Result<(), Bad> {
        let o = &self.optics;
        for (key, v) in [
            ("optics.vignetting_factor", o.vignetting_factor),
            ("optics.rim_width_px", o.rim_width_px),
            ("optics.gamma", o.gamma),
            ("geometry.disc_radius_px", self.geometry.disc_radius_px),
            ("geometry.px_per_mm", self.geometry.px_per_mm),
            ("leds.radius_factor", self.leds.radius_factor),
            ("leds.width_px", self.leds.width_px),
            (
                "indenters.pentagon_circumradius_mm",
                self.indenters.pentagon_circumradius_mm,
            ),
            (
                "indenters.rectangle_width_mm",
                self.indenters.rectangle_width_mm,
            ),
            (
                "indenters.rectangle_height_mm",
                self.indenters.rectangle_height_mm,
            ),
            (
                "indenters.sphere_radius_mm",
                self.indenters.sphere_radius_mm,
            ),
            ("field.cell_mm", self.field.cell_mm),
        ] {
            if !(finite(v) && v > 0.0) {
                return bad(key, v.to_string(), "must be a number > 0");
            }
        }
        Ok(())
    }

    /// The image's size and placement, and the counts (field cells, threads, LEDs).
    fn check_sizes(&self) -> Result<(), Bad> {
        let g = &self.geometry;
        if !(16..=8192).contains(&g.width) {
            return bad(
                "geometry.width",
                g.width.to_string(),
                "must be in 16..=8192 px",
            );
        }
        if !(16..=8192).contains(&g.height) {
            return bad(
                "geometry.height",
                g.height.to_string(),
                "must be in 16..=8192 px",
            );
        }
        if !(g.centre_offset_px.iter().all(|v| v.is_finite()) && g.rotation_deg.is_finite()) {
            return bad(
                "geometry.centre_offset_px / rotation_deg",
                format!("{:?} / {}", g.centre_offset_px, g.rotation_deg),
                "must be finite numbers",
            );
        }
        if !(16..=2048).contains(&self.field.cells) {
            return bad(
                "field.cells",
                self.field.cells.to_string(),
                "must be in 16..=2048",
            );
        }
        if !(1..=64).contains(&self.threads) {
            return bad("threads", self.threads.to_string(), "must be in 1..=64");
        }
        if self.leds.count > 256 {
            return bad(
                "leds.count",
                self.leds.count.to_string(),
                "must be in 0..=256",
            );
        }
        Ok(())
    }

    /// The dead LEDs (each below `leds.count`) and the scratches' ranges.
    fn check_flaws(&self) -> Result<(), Bad> {
        if let Some(k) = self.leds.out.iter().find(|&&k| k >= self.leds.count) {
            return bad(
                "leds.out",
                k.to_string(),
                "each must be an LED index below leds.count (0-based, ring order from phase_deg)",
            );
        }
        let f = &self.surface;
        if !(f.friction_static.is_finite() && (0.05..=5.0).contains(&f.friction_static)) {
            return bad(
                "surface.friction_static",
                f.friction_static.to_string(),
                "must be in 0.05..=5",
            );
        }
        if !(f.friction_kinetic.is_finite()
            && f.friction_kinetic > 0.0
            && f.friction_kinetic <= f.friction_static)
        {
            return bad(
                "surface.friction_kinetic",
                f.friction_kinetic.to_string(),
                "must be above 0 and at most surface.friction_static",
            );
        }
        for (n, scratch) in self.surface.scratches.iter().enumerate() {
            scratch.check().map_err(|b| Bad {
                key: format!("surface.scratches[{n}].{}", b.field),
                value: b.value,
                allowed: b.allowed,
            })?;
        }
        Ok(())
    }

    /// The same unit seen by a camera of `k` times the resolution (a rig file's
    /// `sim.image_scale`): the image and every length given in px (the disc, the scale, the
    /// centre's offset, the blur, the rim ring's width, the LED hot spots' width) scaled by `k`,
    /// so that the picture is the full-size one, sampled more coarsely.
    pub fn scaled(&self, k: f64) -> SensorConfig {
        let mut c = self.clone();
        let g = &mut c.geometry;
        g.width = (f64::from(g.width) * k).round() as u32;
        g.height = (f64::from(g.height) * k).round() as u32;
        g.disc_radius_px *= k;
        g.px_per_mm *= k;
        g.centre_offset_px = g.centre_offset_px.map(|v| v * k);
        c.optics.blur_px *= k;
        c.optics.rim_width_px *= k;
        c.leds.width_px *= k;
        c
    }

    /// The failed LEDs, each once, in ring order.
    pub fn dead_leds(&self) -> Vec<u32> {
        let mut out = self.leds.out.clone();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The photoelastic layer.
    pub fn layer(&self) -> Layer {
        Layer {
            z0_mm: self.layer.top_mm,
            z1_mm: self.layer.bottom_mm,
            nu: self.layer.nu,
        }
    }

    /// The image geometry of this build.
    pub fn geometry(&self) -> SensorGeometry {
        let g = &self.geometry;
        SensorGeometry {
            centre_px: [
                0.5 * g.width as f64 + g.centre_offset_px[0],
                0.5 * g.height as f64 + g.centre_offset_px[1],
            ],
            px_per_mm: g.px_per_mm,
            rotation_deg: g.rotation_deg,
            mirror: g.mirror,
        }
    }

    /// The indenter of class `name` in this build's sizes: what the operator mounts on the
    /// simulated bench when a plan asks for it, the tip `fringe sim dataset` renders. Pentagon,
    /// rectangle and sphere are the build's [`IndenterConfig`]; the circle, which no sensor
    /// definition names, has a radius of [`CIRCLE_RADIUS_MM`].
    pub fn indenter_tip(&self, name: &str) -> Option<IndenterTip> {
        let sizes = &self.indenters;
        Some(match name {
            "pentagon" => IndenterTip::Pentagon {
                circumradius_mm: sizes.pentagon_circumradius_mm,
            },
            "rectangle" => IndenterTip::Rectangle {
                width_mm: sizes.rectangle_width_mm,
                height_mm: sizes.rectangle_height_mm,
            },
            "circle" => IndenterTip::Circle {
                radius_mm: CIRCLE_RADIUS_MM,
            },
            "sphere" => IndenterTip::Sphere {
                radius_mm: sizes.sphere_radius_mm,
            },
            _ => return None,
        })
    }

    /// Pentagon punch of the configured size.
    pub fn pentagon(&self) -> Shape {
        Shape::Pentagon {
            circumradius_mm: self.indenters.pentagon_circumradius_mm,
        }
    }

    /// Rectangular punch of the configured size.
    pub fn rectangle(&self) -> Shape {
        Shape::Rectangle {
            width_mm: self.indenters.rectangle_width_mm,
            height_mm: self.indenters.rectangle_height_mm,
        }
    }

    /// The configured sphere pressed with `force_n` (Hertz contact radius in this gel).
    pub fn sphere(&self, force_n: f64) -> Shape {
        Shape::sphere_hertz(
            self.indenters.sphere_radius_mm,
            force_n,
            self.layer.effective_modulus_mpa,
        )
    }
}

/// A value [`SensorConfig::validate`] refuses: its key, the value and what is allowed.
struct Bad {
    key: String,
    value: String,
    allowed: &'static str,
}

/// Refuses `value` of `key`, saying what is `allowed`.
fn bad(key: &str, value: String, allowed: &'static str) -> Result<(), Bad> {
    Err(Bad {
        key: key.into(),
        value,
        allowed,
    })
}

/// Whether `v` is a finite number.
fn finite(v: f64) -> bool {
    v.is_finite()
}

/// Overlays `file` on `defaults`, one level of tables deep (sections are merged key by key).
fn merge(mut defaults: toml::Table, file: toml::Table) -> toml::Table {
    for (key, value) in file {
        match (defaults.get_mut(&key), value) {
            (Some(toml::Value::Table(base)), toml::Value::Table(over)) => {
                for (k, v) in over {
                    base.insert(k, v);
                }
            }
            (_, value) => {
                defaults.insert(key, value);
            }
        }
    }
    defaults
}

/// The exact map between the sensor frame (mm from the disc centre, +x and +y along the stage
/// axes, seen from the indenter side) and image pixels (column u right, row v down; pixel (i, j)
/// covers u in [i, i + 1), so its centre is at (i + 0.5, j + 0.5)).
///
/// Sensor to image: mirror x (if `mirror`), rotate counter-clockwise by `rotation_deg` (as seen on
/// the image, y up), scale by `px_per_mm`, flip y (rows grow downwards), add `centre_px`.
/// Calibration is scored against this map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorGeometry {
    /// Image position of the sensor frame's origin (optical centre), px [u, v].
    pub centre_px: [f64; 2],
    pub px_per_mm: f64,
    pub rotation_deg: f64,
    pub mirror: bool,
}

impl SensorGeometry {
    /// The 2x2 linear part mapping sensor mm to pixel offsets from the centre.
    pub fn linear(&self) -> [[f64; 2]; 2] {
        let (s, c) = self.rotation_deg.to_radians().sin_cos();
        let m = if self.mirror { -1.0 } else { 1.0 };
        let k = self.px_per_mm;
        // u = k (c m x - s y), v = -k (s m x + c y)
        [[k * c * m, -k * s], [-k * s * m, -k * c]]
    }

    /// Image position (u, v) in px of the sensor-frame point (x, y) in mm.
    pub fn to_pixel(&self, x_mm: f64, y_mm: f64) -> [f64; 2] {
        let a = self.linear();
        [
            self.centre_px[0] + a[0][0] * x_mm + a[0][1] * y_mm,
            self.centre_px[1] + a[1][0] * x_mm + a[1][1] * y_mm,
        ]
    }

    /// Sensor-frame point (x, y) in mm seen at image position (u, v) in px.
    pub fn to_sensor(&self, u: f64, v: f64) -> [f64; 2] {
        let (s, c) = self.rotation_deg.to_radians().sin_cos();
        let m = if self.mirror { -1.0 } else { 1.0 };
        let du = (u - self.centre_px[0]) / self.px_per_mm;
        let dv = -(v - self.centre_px[1]) / self.px_per_mm;
        // Inverse rotation, then inverse mirror.
        let xr = c * du + s * dv;
        let yr = -s * du + c * dv;
        [m * xr, yr]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_round_trips_and_scales() {
        for mirror in [false, true] {
            for rot in [0.0, 37.0, 90.0, -150.0] {
                let g = SensorGeometry {
                    centre_px: [990.0, 594.0],
                    px_per_mm: 18.3,
                    rotation_deg: rot,
                    mirror,
                };
                for &(x, y) in &[(0.0, 0.0), (10.0, -3.0), (-25.0, 17.5)] {
                    let [u, v] = g.to_pixel(x, y);
                    let [x2, y2] = g.to_sensor(u, v);
                    assert!((x - x2).abs() < 1e-9 && (y - y2).abs() < 1e-9, "{x2} {y2}");
                    let dist = (u - 990.0).hypot(v - 594.0);
                    assert!((dist - 18.3 * x.hypot(y)).abs() < 1e-9);
                }
            }
        }
        let g = SensorGeometry {
            centre_px: [100.0, 50.0],
            px_per_mm: 10.0,
            rotation_deg: 0.0,
            mirror: false,
        };
        // +x right, +y up on the image.
        assert_eq!(g.to_pixel(1.0, 0.0), [110.0, 50.0]);
        assert_eq!(g.to_pixel(0.0, 1.0), [100.0, 40.0]);
        let m = SensorGeometry { mirror: true, ..g };
        assert_eq!(m.to_pixel(1.0, 0.0), [90.0, 50.0]);
        let r = SensorGeometry {
            rotation_deg: 90.0,
            ..g
        };
        let [u, v] = r.to_pixel(1.0, 0.0);
        assert!((u - 100.0).abs() < 1e-9 && (v - 40.0).abs() < 1e-9);
    }

    #[test]
    fn file_overrides_variant_defaults_and_names_bad_keys() {
        let c = SensorConfig::from_toml_str(
            "variant = \"integrated\"\nseed = 7\n[optics]\nblur_px = 6.5\n",
            "x.toml",
        )
        .expect("valid");
        assert_eq!(c.variant, Variant::Integrated);
        assert_eq!(c.seed, 7);
        assert_eq!(c.optics.blur_px, 6.5);
        assert_eq!(c.layer.bottom_mm, 20.0);
        assert_eq!(c.optics.gamma, 1.0);

        let e = SensorConfig::from_toml_str("[optics]\nblurr_px = 2\n", "s.toml")
            .expect_err("unknown key")
            .to_string();
        assert!(
            e.contains("s.toml") && e.contains("blurr_px") && e.contains("blur_px"),
            "{e}"
        );
        let e = SensorConfig::from_toml_str("variant = \"thick\"\n", "s.toml")
            .expect_err("bad variant")
            .to_string();
        assert!(e.contains("variant") && e.contains("integrated"), "{e}");
        let e = SensorConfig::from_toml_str("[geometry]\npx_per_mm = -1.0\n", "s.toml")
            .expect_err("negative scale")
            .to_string();
        assert!(e.contains("geometry.px_per_mm") && e.contains("> 0"), "{e}");
        let e = SensorConfig::from_toml_str("[geometry]\nmirror = 3\n", "s.toml")
            .expect_err("wrong type")
            .to_string();
        assert!(e.contains("mirror"), "{e}");
    }

    #[test]
    fn shipped_example_files_load() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("sensors");
        let layered = SensorConfig::load(&dir.join("layered.toml")).expect("layered.toml");
        assert_eq!(layered, SensorConfig::layered());
        let integrated = SensorConfig::load(&dir.join("integrated.toml")).expect("integrated.toml");
        assert_eq!(integrated, SensorConfig::integrated());
        let e = SensorConfig::load(&dir.join("missing.toml")).expect_err("missing");
        assert!(e.to_string().contains("missing.toml"));
    }

    /// Every built-in unit is had by its id, and is the unit its file in rig/sim/sensors/ holds.
    #[test]
    fn every_unit_is_had_by_its_id() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("sensors");
        for id in SensorConfig::UNITS {
            let unit = SensorConfig::unit(id).expect(id);
            assert_eq!(unit.id, id);
            let file = match id {
                "layered-1" => "layered".to_string(),
                "integrated-1" => "integrated".to_string(),
                other => other.to_string(),
            };
            let loaded = SensorConfig::load(&dir.join(format!("{file}.toml"))).expect(id);
            assert_eq!(unit, loaded, "{id}");
        }
        assert!(SensorConfig::unit("layered-9").is_none());
    }

    /// The other units of each design (`layered-2.toml`, ...) load, are named as their files, and
    /// differ from their design where real units do: material, layer, optics, geometry, LEDs and
    /// the seed of their residual stress and noise.
    #[test]
    fn unit_builds_load_and_differ_from_their_design() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("sensors");
        let mut units = 0;
        for entry in std::fs::read_dir(&dir).expect("sensors/") {
            let path = entry.expect("entry").path();
            let name = path.file_stem().and_then(|s| s.to_str()).expect("name");
            if name == "layered" || name == "integrated" {
                continue;
            }
            let unit = SensorConfig::load(&path).expect(name);
            assert_eq!(unit.id, name, "{name}: id differs from the file name");
            let design = match unit.variant {
                Variant::Layered => SensorConfig::layered(),
                Variant::Integrated => SensorConfig::integrated(),
            };
            assert!(name.starts_with(unit.variant.name()), "{name}");
            assert_ne!(unit.seed, design.seed, "{name}: seed");
            assert_ne!(
                unit.layer.f_sigma_n_per_m, design.layer.f_sigma_n_per_m,
                "{name}"
            );
            assert_ne!(
                unit.layer.effective_modulus_mpa, design.layer.effective_modulus_mpa,
                "{name}"
            );
            assert_ne!(unit.optics.blur_px, design.optics.blur_px, "{name}");
            assert_ne!(
                unit.optics.illumination_dn, design.optics.illumination_dn,
                "{name}"
            );
            assert_ne!(
                unit.optics.residual_birefringence, design.optics.residual_birefringence,
                "{name}"
            );
            assert_ne!(
                unit.geometry.centre_offset_px, design.geometry.centre_offset_px,
                "{name}"
            );
            assert_ne!(
                unit.geometry.rotation_deg, design.geometry.rotation_deg,
                "{name}"
            );
            assert_ne!(unit.leds.strength_dn, design.leds.strength_dn, "{name}");
            // Same disc, whatever the camera distance: the stage-to-image scale follows the radius.
            let disc_mm = |c: &SensorConfig| c.geometry.disc_radius_px / c.geometry.px_per_mm;
            assert!((disc_mm(&unit) - disc_mm(&design)).abs() < 0.05, "{name}");
            units += 1;
        }
        assert!(units >= 4, "{units} unit builds in {}", dir.display());
    }
}

#[cfg(test)]
mod slip_onset_tests {
    use super::SensorConfig;
    use crate::physics::traction::partial_slip_onset;
    use fringe_rig::Millimetres;

    /// The rig labels partial slip from its table of the indenters' onsets; the simulator's
    /// ground truth computes them from its traction model. They must agree for every indenter
    /// of both designs.
    #[test]
    fn the_rigs_table_of_partial_slip_onsets_matches_the_traction_model() {
        for sensor in [SensorConfig::layered(), SensorConfig::integrated()] {
            for name in ["pentagon", "rectangle", "circle", "sphere"] {
                let tip = sensor.indenter_tip(name).expect("tip");
                let model = partial_slip_onset(&tip.shape_at(Millimetres(1.0)));
                let table = fringe_rig::partial_slip_onset(name).expect("in the table");
                eprintln!("{name}: model {model:.3}, table {table:.3}");
                assert!((model - table).abs() <= 0.02, "{name}: {model} vs {table}");
            }
        }
    }
}
