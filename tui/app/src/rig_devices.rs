//! The rig file's device sections (`[x]`, `[y]`, `[z]`, `[force]`, `[camera]`) as device
//! descriptions ([`crate::device_spec`]), checked and naming the file and key in errors; the
//! rig opens them with the one opener (`device_open`), as the bring-up commands do theirs.

use crate::device_spec::{
    AxisSpec, CameraSpec, DaqNames, DaqSpec, ForceSpec, ModbusLink, ModbusSpec, NetFtScaling,
    NetFtSpec,
};
use crate::host_port::HostPort;
use crate::rig_file::{
    daq_settings, AxisDriver, AxisSection, CameraDriver, ForceDriver, ForceSection, RigConfig,
};
use fringe_rig::apt::config::{AptConfig, Controller, HomeConfig, HomeDirection, HomeLimitSwitch};
use fringe_rig::apt::status::LimitPolarity;
use fringe_rig::apt::Actuator;
use fringe_rig::atical::ToolTransform;
use fringe_rig::axis::SoftLimits;
use fringe_rig::config_file::ConfigError;
use fringe_rig::netft::{self, Command, NetFtConfig};
use fringe_rig::nidaqmx::CameraTrigger;
use fringe_rig::units::{Millimetres, MillimetresPerSecond, MillimetresPerSecondSquared};

impl RigConfig {
    /// The axis `name` (`x`, `y` or `z`) of a real rig as a device description, with its soft
    /// limits.
    pub fn axis_spec(&self, name: &str, limits: &SoftLimits) -> Result<AxisSpec, ConfigError> {
        let a = match name {
            "x" => &self.file.x,
            "y" => &self.file.y,
            "z" => &self.file.z,
            other => {
                return Err(self.err(format!(
                    "no axis [{other}] in a rig file (the axes are x, y and z)"
                )))
            }
        };
        let port = || {
            a.port.clone().ok_or_else(|| {
                self.err(format!(
                    "[{name}]: key `{name}.port` (the serial port, e.g. /dev/ttyUSB0) is required for driver {:?}",
                    a.driver
                ))
            })
        };
        match a.driver {
            AxisDriver::Sim => Err(self.err(format!(
                "key `{name}.driver` = \"sim\" on a real rig: a rig is wholly simulated or wholly real"
            ))),
            AxisDriver::Thorlabs => Ok(AxisSpec::Thorlabs {
                config: self.apt_config(name, a, limits)?,
                port: port()?,
            }),
            AxisDriver::ModbusRtu | AxisDriver::ModbusTcp => {
                let map = a.map.clone().ok_or_else(|| {
                    self.err(format!(
                        "[{name}]: key `{name}.map` (oriental-az, leadshine-pr or a register map file) is required for a Modbus stage"
                    ))
                })?;
                let link = if a.driver == AxisDriver::ModbusRtu {
                    ModbusLink::Rtu { port: port()? }
                } else {
                    let text = a.address.as_deref().ok_or_else(|| {
                        self.err(format!(
                            "[{name}]: key `{name}.address` (host:port) is required for a Modbus TCP stage"
                        ))
                    })?;
                    ModbusLink::Tcp(
                        HostPort::parse(text, None)
                            .map_err(|e| self.err(format!("key `{name}.address`: {e}")))?,
                    )
                };
                Ok(AxisSpec::Modbus(ModbusSpec {
                    name: name.to_string(),
                    link,
                    map,
                    slave: a.slave,
                    baud: a.baud,
                    limits: Some(*limits),
                }))
            }
            AxisDriver::Manual => Ok(AxisSpec::Manual {
                name: name.to_string(),
                limits: Some(*limits),
            }),
        }
    }

    /// The Thorlabs settings of axis `name` from its section.
    pub(crate) fn apt_config(
        &self,
        name: &str,
        a: &AxisSection,
        limits: &SoftLimits,
    ) -> Result<AptConfig, ConfigError> {
        let actuator_name = a.actuator.as_deref().ok_or_else(|| {
            self.err(format!(
                "[{name}]: key `{name}.actuator` is required for a Thorlabs axis (known: {})",
                Actuator::known_names()
            ))
        })?;
        let actuator = Actuator::by_name(actuator_name).ok_or_else(|| {
            self.err(format!(
                "key `{name}.actuator` = {actuator_name:?}: unknown (known: {})",
                Actuator::known_names()
            ))
        })?;
        let controller = match a.controller.as_deref() {
            None => Controller::Kst101,
            Some(c) => c
                .parse::<Controller>()
                .map_err(|e| self.err(format!("key `{name}.controller`: {e}")))?,
        };
        let mut c = AptConfig::new(name, controller, actuator);
        c.bay = a.bay;
        if let Some(ch) = a.channel {
            c.channel = ch;
        }
        c.velocity = MillimetresPerSecond(a.velocity.unwrap_or(1.0));
        c.acceleration = MillimetresPerSecondSquared(a.acceleration.unwrap_or(1.0));
        c.soft_limits = Some(*limits);
        if let Some(h) = &a.home {
            let side = |key: &str, v: &str| match v {
                "reverse" => Ok(false),
                "forward" => Ok(true),
                other => Err(self.err(format!(
                    "key `{name}.home.{key}` = {other:?}: use reverse or forward"
                ))),
            };
            c.home = HomeConfig {
                direction: if side("direction", &h.direction)? {
                    HomeDirection::Forward
                } else {
                    HomeDirection::Reverse
                },
                limit_switch: if side("limit_switch", &h.limit_switch)? {
                    HomeLimitSwitch::Forward
                } else {
                    HomeLimitSwitch::Reverse
                },
                velocity: MillimetresPerSecond(h.velocity.unwrap_or(c.velocity.0.min(1.0))),
                offset: Millimetres(h.offset),
            };
        } else {
            c.home.velocity = MillimetresPerSecond(c.velocity.0.min(1.0));
        }
        c.limit_polarity = match a.limit_polarity.as_deref() {
            None | Some("bit0-forward") => LimitPolarity::Bit0Forward,
            Some("bit0-reverse") => LimitPolarity::Bit0Reverse,
            Some(other) => {
                return Err(self.err(format!(
                    "key `{name}.limit_polarity` = {other:?}: use bit0-forward or bit0-reverse"
                )))
            }
        };
        Ok(c)
    }

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

    /// `[force]` with driver "nidaqmx".
    fn daq_spec(&self, f: &ForceSection) -> Result<DaqSpec, ConfigError> {
        let settings =
            daq_settings(f).map_err(|(key, message)| self.err(format!("{key}: {message}")))?;
        let cal_file = f.cal_file.clone().ok_or_else(|| {
            self.err(
                "key `force.cal_file` (the transducer's ATI .cal file) is required for driver \"nidaqmx\"".into(),
            )
        })?;
        let tool = match (f.tool_translation_m, f.tool_rotation_deg) {
            (None, None) => None,
            (d, r) => {
                let d = d.unwrap_or([0.0; 3]);
                let r = r.unwrap_or([0.0; 3]);
                if let Some((key, _)) = [("tool_translation_m", d), ("tool_rotation_deg", r)]
                    .into_iter()
                    .find(|(_, v)| v.iter().any(|x| !x.is_finite()))
                {
                    return Err(self.err(format!(
                        "key `force.{key}`: must be three finite numbers (tool_translation_m in metres, tool_rotation_deg in degrees)"
                    )));
                }
                Some(ToolTransform::from_ati(d, r.map(f64::to_radians)))
            }
        };
        let camera_trigger = match self.daq_triggers_camera()? {
            true => Some(CameraTrigger {
                counter: f.trigger_counter.clone().unwrap_or_else(|| "ctr0".into()),
                terminal: f.trigger_terminal.clone(),
                frame_rate: self.camera_settings()?.frame_rate,
                duty: 0.5,
            }),
            false => None,
        };
        Ok(DaqSpec {
            settings,
            cal_file,
            library: f.library.clone(),
            tool,
            camera_trigger,
            named_by: DaqNames::RigFile,
        })
    }

    /// `[force]` with driver "netft".
    fn netft_spec(&self, f: &ForceSection) -> Result<NetFtSpec, ConfigError> {
        let text = f.address.as_deref().ok_or_else(|| {
            self.err("key `force.address` (the Net F/T's host or host:port) is required".into())
        })?;
        let address = HostPort::parse(text, Some(netft::DEFAULT_PORT))
            .map_err(|e| self.err(format!("key `force.address`: {e}")))?;
        let scaling = match (f.cpf, f.cpt) {
            (Some(cpf), Some(cpt)) => NetFtScaling::Given(
                NetFtConfig::new(
                    cpf,
                    cpt,
                    f.force_unit.as_deref().unwrap_or("N"),
                    f.torque_unit.as_deref().unwrap_or("Nm"),
                    "[force] cpf/cpt",
                )
                .map_err(|e| self.err(e.to_string()))?,
            ),
            (None, None) => NetFtScaling::FromBox { url: None },
            _ => return Err(self.err(
                "[force]: give both `cpf` and `cpt`, or neither (then they are read from the box)"
                    .into(),
            )),
        };
        Ok(NetFtSpec::new(address, scaling, Command::RealTime))
    }

    /// The `[camera]` section of a real rig as a device description.
    pub fn camera_spec(&self) -> Result<CameraSpec, ConfigError> {
        match self.file.camera.driver {
            CameraDriver::Aravis => Ok(CameraSpec::Aravis {
                id: self.file.camera.id.clone(),
            }),
            CameraDriver::Sim => Err(self.err(
                "key `camera.driver` = \"sim\" on a real rig: a rig is wholly simulated or wholly real (use driver = \"aravis\")".into(),
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::device_open::{open_force, DeviceError};
    use crate::device_spec::{DaqNames, DaqSpec, ForceSpec};
    use crate::rig_file::RigConfig;
    use fringe_rig::nidaqmx::{DaqSettings, Terminal};
    use fringe_rig::sync::method::SyncMethod;
    use fringe_rig::units::{Hertz, Volts};
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
        let reference = include_str!("../rigs/reference-bench.toml");
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
        use crate::device_open::daq_error;
        use fringe_rig::nidaqmx::api::status;
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
                status::INVALID_DEVICE_ID,
                "Device identifier is invalid.",
                "key `force.device`",
                "--device",
                "NI MAX",
            ),
            (
                Setting::Gauges,
                status::PHYSICAL_CHAN_DOES_NOT_EXIST,
                "Physical channel specified does not exist on this device.",
                "key `force.gauges`",
                "--channels",
                "six gauge channels",
            ),
            (
                Setting::Strobe,
                status::PHYSICAL_CHAN_DOES_NOT_EXIST,
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
            ni(status::DEV_CANNOT_BE_ACCESSED, "Device cannot be accessed."),
        );
        let line = daq_error(&spec(DaqNames::RigFile), e).to_string();
        assert!(
            line.contains("plug it in again") && !line.contains("key `"),
            "{line}"
        );
    }
}
