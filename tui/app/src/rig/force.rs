//! The F/T door: every force/torque interface described by one [`ForceSpec`] and opened by one
//! [`open_force`], for the rig and for the bring-up commands alike. Each interface is a module of
//! its own, its description and its opener: [`netft`] (an ATI Net F/T over RDT/UDP) and
//! [`nidaqmx`] (an ATI transducer's gauges read by an NI-DAQmx device).
//!
//! The rig file's `[force]` section is [`section`]'s: the `driver`, the keys each interface
//! takes and their checks.
//!
//! A new interface: its module here; a variant of [`ForceSpec`] with its arms, and its arms in
//! [`open_force`] and `RigConfig::force_spec`; its `driver` and keys in [`section`].

pub(crate) mod netft;
pub(crate) mod nidaqmx;
pub(crate) mod section;

use crate::rig::device_open::{DeviceError, TraceTo};
use crate::rig::file::RigConfig;
use fringe_rig::ConfigError;
use fringe_rig::ForceSensor;
use netft::{open_netft, NetFtSpec};
use nidaqmx::{open_daq, DaqSpec};
use section::ForceDriver;
use std::path::Path;

/// A force/torque sensor: one variant per interface, all opened by `open_force`.
#[derive(Debug, Clone, PartialEq)]
pub enum ForceSpec {
    /// An ATI Net F/T or Ethernet Axia over RDT/UDP.
    NetFt(NetFtSpec),
    /// An ATI transducer's gauges read by an NI-DAQmx device, converted by its `.cal` file.
    NiDaqmx(DaqSpec),
}

impl ForceSpec {
    /// One line for the rig's device list.
    pub fn describe(&self) -> String {
        match self {
            ForceSpec::NetFt(n) => n.describe(),
            ForceSpec::NiDaqmx(d) => d.describe(),
        }
    }

    /// Whether the force stream carries the camera's exposure strobe (strobe sync possible).
    pub fn records_strobe(&self) -> bool {
        match self {
            ForceSpec::NetFt(_) => false,
            ForceSpec::NiDaqmx(d) => d.settings.strobe.is_some(),
        }
    }

    /// The name of its trace under `--record-trace DIR` (`DIR/<name>.trace`).
    pub fn trace_name(&self) -> &'static str {
        match self {
            ForceSpec::NetFt(_) => "netft",
            ForceSpec::NiDaqmx(_) => "force",
        }
    }
}

/// The force sensor `spec` describes, whatever its interface; `record_trace` records its
/// traffic to `DIR/<name>.trace` ([`ForceSpec::trace_name`]).
pub(crate) fn open_force(
    spec: &ForceSpec,
    record_trace: Option<&Path>,
) -> Result<Box<dyn ForceSensor>, DeviceError> {
    let trace = TraceTo::new(record_trace, spec.trace_name());
    Ok(match spec {
        ForceSpec::NetFt(n) => Box::new(open_netft(n, trace)?),
        ForceSpec::NiDaqmx(d) => Box::new(open_daq(d, trace)?),
    })
}

impl RigConfig {
    /// The `[force]` section of a real rig as a device description.
    pub fn force_spec(&self) -> Result<ForceSpec, ConfigError> {
        let f = &self.file.force;
        match f.driver {
            ForceDriver::Sim => Err(self.err(
                "key `force.driver` = \"sim\" on a real rig: a rig is wholly simulated or wholly real (use driver = \"netft\" or \"nidaqmx\")".into(),
            )),
            ForceDriver::Netft => Ok(ForceSpec::NetFt(self.netft_spec(f)?)),
            ForceDriver::Nidaqmx => Ok(ForceSpec::NiDaqmx(self.daq_spec(f)?)),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::rig::device_open::DeviceError;
    use crate::rig::file::RigConfig;
    use crate::rig::force::nidaqmx::names::DaqNames;
    use crate::rig::force::nidaqmx::DaqSpec;
    use crate::rig::force::{open_force, ForceSpec};
    use fringe_rig::nidaqmx::{DaqSettings, Terminal};
    use fringe_rig::SyncMethod;
    use fringe_rig::{Hertz, Volts};
    use std::path::{Path, PathBuf};

    /// A real rig whose `[force]` section is `force`.
    fn rig(force: &str, extra: &str) -> String {
        format!(
            "{extra}[x]\ndriver = \"thorlabs\"\n[y]\ndriver = \"manual\"\n[z]\ndriver = \"thorlabs\"\n[force]\n{force}\n[camera]\ndriver = \"aravis\"\n"
        )
    }

    fn parse(force: &str) -> Result<RigConfig, String> {
        RigConfig::parse(&rig(force, ""), "rig.toml").map_err(|e| e.to_string())
    }

    fn cal_file() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/mini40-v1.1.cal")
    }

    #[test]
    fn a_daq_rig_file_gives_its_settings_and_the_defaults() {
        let c = parse(
            "driver = \"nidaqmx\"\ndevice = \"Dev2\"\ngauges = \"ai8:13\"\nstrobe = \"ai15\"\nterminal = \"rse\"\nrange_v = 5.0\nrate_hz = 2000.0\nbuffer_scans = 20000\ncal_file = \"FT1234.cal\"\nlibrary = \"/opt/ni/libnidaqmx.so.1\"\ntool_translation_m = [0.0, 0.0, 0.05]",
        )
        .expect("parses");
        let ForceSpec::NiDaqmx(spec) = c.force_spec().expect("spec") else {
            panic!("not a DAQ");
        };
        assert_eq!(
            spec.settings,
            DaqSettings {
                device: "Dev2".into(),
                gauges: "ai8:13".into(),
                strobe: Some("ai15".into()),
                terminal: Terminal::Rse,
                range: Volts(5.0),
                rate: Hertz(2000.0),
                buffer_scans: Some(20000),
            }
        );
        assert_eq!(spec.cal_file, PathBuf::from("FT1234.cal"));
        assert_eq!(
            spec.library.as_deref(),
            Some(Path::new("/opt/ni/libnidaqmx.so.1"))
        );
        let tool = spec.tool.expect("tool transform");
        let w = tool.apply([0.0, 10.0, 0.0, 0.0, 0.0, 0.0]);
        assert!((w[3] - 0.5).abs() < 1e-12, "Tx' = Tx + Dz*Fy: {w:?}");
        assert_eq!(spec.named_by, DaqNames::RigFile);
        assert_eq!(
            c.sync().expect("sync"),
            SyncMethod::Strobe,
            "a strobe is wired"
        );

        let c = parse("driver = \"nidaqmx\"\ncal_file = \"FT1234.cal\"").expect("parses");
        let ForceSpec::NiDaqmx(spec) = c.force_spec().expect("spec") else {
            panic!("not a DAQ");
        };
        assert_eq!(spec.settings, DaqSettings::default());
        assert_eq!((spec.library, spec.tool), (None, None));
        assert_eq!(c.sync().expect("sync"), SyncMethod::ClockFit, "no strobe");
        let strobe = RigConfig::parse(
            &rig(
                "driver = \"nidaqmx\"\ncal_file = \"FT1234.cal\"",
                "sync = \"strobe\"\n",
            ),
            "rig.toml",
        )
        .expect("parses")
        .sync()
        .expect_err("no strobe channel")
        .to_string();
        assert!(
            strobe.starts_with("rig.toml: key `sync` = \"strobe\"")
                && strobe.contains("`force.strobe`"),
            "{strobe}"
        );
    }

    #[test]
    fn each_bad_force_key_is_refused_naming_it() {
        let daq = "driver = \"nidaqmx\"\ncal_file = \"FT1234.cal\"\n";
        for (section, key, words) in [
            (
                format!("{daq}terminal = \"floating\""),
                "force.terminal",
                "diff, rse",
            ),
            (format!("{daq}range_v = -10.0"), "force.range_v", "positive"),
            (format!("{daq}rate_hz = 0.0"), "force.rate_hz", "positive"),
            (
                format!("{daq}buffer_scans = 0"),
                "force.buffer_scans",
                "default",
            ),
            (
                format!("{daq}gauges = \"ai0:4\""),
                "force.gauges",
                "names 5",
            ),
            (
                format!("{daq}gauges = \"six\""),
                "force.gauges",
                "channel name",
            ),
            (
                format!("{daq}strobe = \"ai6:7\""),
                "force.strobe",
                "one channel",
            ),
            (
                format!("{daq}device = \"Dev1/ai0\""),
                "force.device",
                "device name",
            ),
            (
                format!("{daq}tool_rotation_deg = [0.0, nan, 0.0]"),
                "force.tool_rotation_deg",
                "finite",
            ),
            ("driver = \"nidaqmx\"".into(), "force.cal_file", "required"),
            (
                format!("{daq}address = \"10.0.0.2\""),
                "force.address",
                "Net F/T",
            ),
            (format!("{daq}cpf = 1000000.0"), "force.cpf", "Net F/T"),
            (
                "driver = \"netft\"\naddress = \"10.0.0.2\"\ncal_file = \"x.cal\"".into(),
                "force.cal_file",
                "NI-DAQmx",
            ),
            (
                "driver = \"netft\"\naddress = \"10.0.0.2\"\nstrobe = \"ai7\"".into(),
                "force.strobe",
                "NI-DAQmx",
            ),
        ] {
            let e = match parse(&section) {
                Err(e) => e,
                Ok(c) => c
                    .force_spec()
                    .map(|s| format!("accepted {s:?}"))
                    .unwrap_or_else(|e| e.to_string()),
            };
            assert!(
                e.starts_with("rig.toml: key `")
                    && e.contains(&format!("`{key}`"))
                    && e.contains(words),
                "{section}: {e}"
            );
        }
        // The simulated bench takes no DAQ key either.
        let e = RigConfig::parse("[force]\nrate_hz = 1000.0\n", "rig.toml")
            .expect_err("sim with a DAQ key")
            .to_string();
        assert!(
            e.contains("key `force.rate_hz`") && e.contains("sim.force_path"),
            "{e}"
        );
    }

    fn daq_spec(cal_file: PathBuf, library: &str, named_by: DaqNames) -> ForceSpec {
        ForceSpec::NiDaqmx(DaqSpec {
            settings: DaqSettings::default(),
            cal_file,
            library: Some(PathBuf::from(library)),
            tool: None,
            camera_trigger: None,
            named_by,
        })
    }

    fn open_error(spec: &ForceSpec) -> String {
        match open_force(spec, None) {
            Ok(s) => panic!("opened {}", s.describe()),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn a_missing_library_is_one_line_naming_the_library_the_install_and_the_key() {
        let lib = "/nonexistent/ni/libnidaqmx.so.1";
        let e = open_error(&daq_spec(cal_file(), lib, DaqNames::RigFile));
        assert!(!e.contains('\n'), "one line: {e}");
        for part in [
            lib,
            "install NI-DAQmx for Linux",
            "ni-daqmx",
            "`force.library`",
            "--library",
        ] {
            assert!(e.contains(part), "{e} lacks {part}");
        }
        let e = open_error(&daq_spec(cal_file(), lib, DaqNames::Flags));
        assert!(e.contains("--library PATH") && e.contains(lib), "{e}");
    }

    #[test]
    fn the_rig_files_force_spec_opens_its_own_driver_through_the_one_door() {
        // A DAQ rig reaches the DAQ opener: its .cal file is read first, named by its key.
        let c = parse("driver = \"nidaqmx\"\ncal_file = \"/nonexistent/FT1234.cal\"\nlibrary = \"/nonexistent/libnidaqmx.so\"")
            .expect("parses");
        let spec = c.force_spec().expect("spec");
        assert_eq!(spec.trace_name(), "force");
        let e = open_error(&spec);
        assert!(
            e.starts_with("force: key `force.cal_file`") && e.contains("/nonexistent/FT1234.cal"),
            "{e}"
        );
        match open_force(
            &daq_spec(cal_file(), "/nonexistent/l.so", DaqNames::RigFile),
            None,
        ) {
            Err(DeviceError::Daq { error, .. }) => {
                assert_eq!(error.setting(), Some(fringe_rig::nidaqmx::Setting::Library))
            }
            Err(e) => panic!("not the DAQ opener's error: {e}"),
            Ok(_) => panic!("opened without a library"),
        }
        // A Net F/T rig reaches the Net F/T opener (with its counts given, opening is a socket).
        let c = parse("driver = \"netft\"\naddress = \"127.0.0.1:49152\"\ncpf = 1.0\ncpt = 1.0")
            .expect("parses");
        let spec = c.force_spec().expect("spec");
        assert!(!spec.records_strobe());
        assert_eq!(spec.trace_name(), "netft", "existing trace names are kept");
        let sensor = open_force(&spec, None).expect("a UDP socket opens");
        assert!(
            sensor.describe().contains("127.0.0.1:49152"),
            "{}",
            sensor.describe()
        );
    }

    #[test]
    fn a_daq_rigs_cal_file_gives_the_transducers_rating_before_anything_opens() {
        let reference = include_str!("../../rigs/reference-bench.toml");
        let line = reference
            .lines()
            .find(|l| l.starts_with("address = "))
            .expect("the reference bench's address");
        let daq = |cal: &Path, max_force: &str| {
            reference
                .replace(
                    &format!("driver = \"netft\"\n{line}"),
                    &format!(
                        "driver = \"nidaqmx\"\ncal_file = {:?}\nstrobe = \"ai7\"",
                        cal.display().to_string()
                    ),
                )
                .replace("max_force = 20.0", max_force)
        };
        let c = RigConfig::parse(&daq(&cal_file(), "max_force = 20.0"), "r.toml").expect("parses");
        let rated = fringe_rig::atical::Calibration::load(&cal_file())
            .expect("cal")
            .max_loads[2];
        let limits = c.limits().expect("limits");
        assert_eq!(limits.ft_rating.as_ref().map(|r| r.fz.0), Some(rated));
        assert_eq!(c.ft_rating_warning(), None, "the rating is known");
        let too_much = format!("max_force = {}", (rated + 50.0).round());
        let e = RigConfig::parse(&daq(&cal_file(), &too_much), "r.toml")
            .expect("parses")
            .limits()
            .expect_err("above the rating")
            .to_string();
        assert!(
            e.contains("force.max_force") && e.contains("rated range"),
            "{e}"
        );
        let e = RigConfig::parse(
            &daq(Path::new("/nonexistent/FT9.cal"), "max_force = 20.0"),
            "r.toml",
        )
        .expect("parses")
        .check_before_open()
        .expect_err("no .cal file")
        .to_string();
        assert!(
            e.starts_with("r.toml: key `force.cal_file`") && e.contains("/nonexistent/FT9.cal"),
            "{e}"
        );
    }

    #[test]
    fn nis_refusals_at_open_name_the_key_or_flag_and_what_to_do() {
        use crate::rig::force::nidaqmx::daq_error;
        use fringe_rig::nidaqmx;
        use fringe_rig::nidaqmx::{DaqError, DaqmxStatus, Setting};
        let ni = |code, text: &str| DaqmxStatus {
            code,
            text: text.into(),
        };
        let spec = |named_by| DaqSpec {
            settings: DaqSettings::default(),
            cal_file: cal_file(),
            library: None,
            tool: None,
            camera_trigger: None,
            named_by,
        };
        for (setting, code, text, key, flag, advice) in [
            (
                Setting::Device,
                nidaqmx::INVALID_DEVICE_ID,
                "Device identifier is invalid.",
                "key `force.device`",
                "--device",
                "NI MAX",
            ),
            (
                Setting::Gauges,
                nidaqmx::PHYSICAL_CHAN_DOES_NOT_EXIST,
                "Physical channel specified does not exist on this device.",
                "key `force.gauges`",
                "--channels",
                "six gauge channels",
            ),
            (
                Setting::Strobe,
                nidaqmx::PHYSICAL_CHAN_DOES_NOT_EXIST,
                "Physical channel specified does not exist on this device.",
                "key `force.strobe`",
                "--strobe",
                "exposure signal",
            ),
            (
                Setting::Rate,
                -200077,
                "Requested value is not a supported value for this property.",
                "key `force.rate_hz`",
                "--rate",
                "scan rate",
            ),
            (
                Setting::Range,
                -200077,
                "Requested value is not a supported value for this property.",
                "key `force.range_v`",
                "--range",
                "input range",
            ),
        ] {
            for (named_by, name) in [(DaqNames::RigFile, key), (DaqNames::Flags, flag)] {
                let e = DaqError::sort("Dev1", setting, "DAQmxCreateAIVoltageChan", ni(code, text));
                let line = daq_error(&spec(named_by), e).to_string();
                assert!(
                    !line.contains('\n')
                        && line.contains(name)
                        && line.contains(text)
                        && line.contains(advice),
                    "{line}"
                );
            }
        }
        // A device that went away names no setting: the driver's own advice is the line.
        let e = DaqError::sort(
            "Dev1",
            Setting::Device,
            "DAQmxReadAnalogF64",
            ni(
                nidaqmx::DEV_CANNOT_BE_ACCESSED,
                "Device cannot be accessed.",
            ),
        );
        let line = daq_error(&spec(DaqNames::RigFile), e).to_string();
        assert!(
            line.contains("plug it in again") && !line.contains("key `"),
            "{line}"
        );
    }

    /// `[force] x_axis_deg` and `z_toward_tool` say how the F/T's axes sit on the bench, for
    /// shear in the sensor's frame; refused where they cannot mean anything.
    #[test]
    fn the_f_t_axes_come_from_the_force_section_and_are_checked() {
        let netft = "driver = \"netft\"\naddress = \"192.168.1.1\"";
        let c = parse(&format!(
            "{netft}\nx_axis_deg = 90.0\nz_toward_tool = false"
        ))
        .expect("parses");
        assert_eq!(
            c.file.force.ft_axes(),
            Some(fringe_rig::FtAxes {
                x_axis_deg: 90.0,
                z_toward_tool: false
            })
        );
        // ATI's tool frame unless told otherwise; nothing without the angle.
        let c = parse(&format!("{netft}\nx_axis_deg = 0.0")).expect("parses");
        assert_eq!(c.file.force.ft_axes().map(|a| a.z_toward_tool), Some(true));
        assert_eq!(parse(netft).expect("parses").file.force.ft_axes(), None);
        let e = parse(&format!("{netft}\nz_toward_tool = true")).expect_err("no angle");
        assert!(
            e.contains("`force.z_toward_tool` needs `force.x_axis_deg`"),
            "{e}"
        );
        let e = parse(&format!("{netft}\nx_axis_deg = nan")).expect_err("not a number");
        assert!(e.contains("`force.x_axis_deg` = NaN"), "{e}");
        let e = RigConfig::parse("[force]\nx_axis_deg = 0.0\n", "rig.toml")
            .expect_err("the simulated bench's axes are its mount's")
            .to_string();
        assert!(e.contains("force.x_axis_deg") && e.contains("mount"), "{e}");
    }
}
