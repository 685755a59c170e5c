//! A fake `libnidaqmx.so` for tests without NI hardware: the simulated NI-DAQmx library of
//! `fringe-sim` (NI's documented behaviour: a hardware-paced sample clock, the circular buffer
//! and its overflow error, read timeouts, reserved devices, an unplug), exported under NI's
//! function names with NI's C signatures.
//!
//! The devices come from the TOML file named by `FRINGE_FAKE_NIDAQMX`, read at the first call
//! (without it: one USB-6218 named Dev1 whose inputs read 0 V):
//!
//! ```toml
//! [[device]]
//! name = "Dev1"
//! product = "USB-6218"        # the only model simulated
//! clock_drift_ppm = 0.0
//! unplug_after_s = 2.0         # the cable is pulled this long after the first start
//! volts = { ai0 = 0.5, ai1 = -0.25 }   # constant inputs; the others read 0 V
//! [device.square.ai7]          # a square wave: the camera's exposure strobe
//! high = 3.3
//! low = 0.0
//! frequency_hz = 50.0
//! duty = 0.3
//! ```
//!
//! `fringe_fake_nidaqmx_unplug(name, unplugged)` pulls or plugs a device's cable at once.

use fringe_rig::nidaqmx::{Functions, TaskHandle};
use fringe_rig::HostTime;
use fringe_sim::daqmx_device;
use fringe_sim::install_daqmx_device;
use fringe_sim::lookup_daqmx_symbol;
use fringe_sim::{DaqSignals, DeviceModel, DeviceTiming, SimDevice};
use std::collections::BTreeMap;
use std::ffi::{c_char, c_double, c_int, c_uint, CStr};
use std::sync::OnceLock;
use std::time::Duration;

#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Square {
    high: f64,
    low: f64,
    frequency_hz: f64,
    duty: f64,
}

#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct DeviceConfig {
    name: String,
    #[serde(default)]
    product: Option<String>,
    #[serde(default)]
    clock_drift_ppm: f64,
    #[serde(default)]
    unplug_after_s: Option<f64>,
    #[serde(default)]
    volts: BTreeMap<String, f64>,
    #[serde(default)]
    square: BTreeMap<String, Square>,
}

#[derive(Debug, Default, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Config {
    #[serde(default)]
    device: Vec<DeviceConfig>,
}

/// Constant inputs and square waves, by channel number.
struct FakeSignals {
    volts: BTreeMap<u32, f64>,
    square: BTreeMap<u32, Square>,
    start: HostTime,
}

impl DaqSignals for FakeSignals {
    fn scan(&mut self, _index: u64, t: HostTime, channels: &[u32], out: &mut [f64]) {
        let since = t.0.saturating_sub(self.start.0) as f64 * 1e-9;
        for (o, ch) in out.iter_mut().zip(channels) {
            *o = match self.square.get(ch) {
                Some(s) => {
                    if (since * s.frequency_hz).fract() < s.duty {
                        s.high
                    } else {
                        s.low
                    }
                }
                None => self.volts.get(ch).copied().unwrap_or(0.0),
            };
        }
    }

    fn started(&mut self, start: HostTime, _rate_hz: f64, _drift_ppm: f64) {
        self.start = start;
    }
}

fn channel_number(name: &str) -> u32 {
    name.trim_start_matches("ai").parse().unwrap_or_else(|_| {
        panic!("FRINGE_FAKE_NIDAQMX: {name:?} is not an analogue input name such as ai0")
    })
}

fn install(config: Config) {
    let devices = if config.device.is_empty() {
        vec![DeviceConfig {
            name: "Dev1".into(),
            product: None,
            clock_drift_ppm: 0.0,
            unplug_after_s: None,
            volts: BTreeMap::new(),
            square: BTreeMap::new(),
        }]
    } else {
        config.device
    };
    for d in devices {
        if let Some(p) = &d.product {
            assert_eq!(
                p, "USB-6218",
                "FRINGE_FAKE_NIDAQMX: only the USB-6218 is simulated"
            );
        }
        let signals = FakeSignals {
            volts: d
                .volts
                .iter()
                .map(|(k, v)| (channel_number(k), *v))
                .collect(),
            square: d
                .square
                .iter()
                .map(|(k, v)| (channel_number(k), v.clone()))
                .collect(),
            start: HostTime(0),
        };
        install_daqmx_device(SimDevice::new(
            &d.name,
            DeviceModel::usb_6218(),
            DeviceTiming {
                clock_drift_ppm: d.clock_drift_ppm,
                unplug_after: d.unplug_after_s.map(Duration::from_secs_f64),
                ..DeviceTiming::default()
            },
            Box::new(signals),
        ));
    }
}

/// The simulated library's functions, the devices installed at the first call.
fn fns() -> &'static Functions {
    static FNS: OnceLock<Functions> = OnceLock::new();
    FNS.get_or_init(|| {
        let config = match std::env::var_os("FRINGE_FAKE_NIDAQMX") {
            Some(path) => {
                let text = std::fs::read_to_string(&path)
                    .unwrap_or_else(|e| panic!("FRINGE_FAKE_NIDAQMX: cannot read {path:?}: {e}"));
                toml::from_str(&text)
                    .unwrap_or_else(|e| panic!("FRINGE_FAKE_NIDAQMX: {path:?}: {e}"))
            }
            None => Config::default(),
        };
        install(config);
        // SAFETY: `lookup_daqmx_symbol` gives functions with NI's signatures, for the program's life.
        unsafe { Functions::resolve(lookup_daqmx_symbol) }
            .unwrap_or_else(|missing| panic!("the simulated library lacks {missing}"))
    })
}

/// A status for a function the simulated library lacks (it has all of these).
const MISSING: c_int = -200000;

/// # Safety
/// NI's contract for `DAQmxCreateTask`.
#[no_mangle]
pub unsafe extern "C" fn DAQmxCreateTask(name: *const c_char, handle: *mut TaskHandle) -> c_int {
    // SAFETY: passed on.
    unsafe { (fns().create_task)(name, handle) }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxStartTask(handle: TaskHandle) -> c_int {
    // SAFETY: passed on.
    unsafe { (fns().start_task)(handle) }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxStopTask(handle: TaskHandle) -> c_int {
    // SAFETY: passed on.
    unsafe { (fns().stop_task)(handle) }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxClearTask(handle: TaskHandle) -> c_int {
    // SAFETY: passed on.
    unsafe { (fns().clear_task)(handle) }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxTaskControl(handle: TaskHandle, action: c_int) -> c_int {
    match fns().task_control {
        // SAFETY: passed on.
        Some(f) => unsafe { f(handle, action) },
        None => MISSING,
    }
}

/// # Safety
/// NI's contract.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn DAQmxCreateAIVoltageChan(
    handle: TaskHandle,
    channel: *const c_char,
    name: *const c_char,
    terminal: c_int,
    min: c_double,
    max: c_double,
    units: c_int,
    scale: *const c_char,
) -> c_int {
    // SAFETY: passed on.
    unsafe {
        (fns().create_ai_voltage_chan)(handle, channel, name, terminal, min, max, units, scale)
    }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxCfgSampClkTiming(
    handle: TaskHandle,
    source: *const c_char,
    rate: c_double,
    edge: c_int,
    mode: c_int,
    samps: u64,
) -> c_int {
    // SAFETY: passed on.
    unsafe { (fns().cfg_samp_clk_timing)(handle, source, rate, edge, mode, samps) }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxCfgInputBuffer(handle: TaskHandle, scans: c_uint) -> c_int {
    match fns().cfg_input_buffer {
        // SAFETY: passed on.
        Some(f) => unsafe { f(handle, scans) },
        None => MISSING,
    }
}

/// # Safety
/// NI's contract.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn DAQmxReadAnalogF64(
    handle: TaskHandle,
    num: c_int,
    timeout: c_double,
    fill: c_uint,
    array: *mut c_double,
    size: c_uint,
    read: *mut c_int,
    reserved: *mut c_uint,
) -> c_int {
    // SAFETY: passed on.
    unsafe { (fns().read_analog_f64)(handle, num, timeout, fill, array, size, read, reserved) }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxGetReadTotalSampPerChanAcquired(
    handle: TaskHandle,
    data: *mut u64,
) -> c_int {
    match fns().get_read_total_samp_per_chan_acquired {
        // SAFETY: passed on.
        Some(f) => unsafe { f(handle, data) },
        None => MISSING,
    }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxGetExtendedErrorInfo(buf: *mut c_char, size: c_uint) -> c_int {
    // SAFETY: passed on.
    unsafe { (fns().get_extended_error_info)(buf, size) }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxGetErrorString(code: c_int, buf: *mut c_char, size: c_uint) -> c_int {
    match fns().get_error_string {
        // SAFETY: passed on.
        Some(f) => unsafe { f(code, buf, size) },
        None => MISSING,
    }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxGetDevProductType(
    device: *const c_char,
    buf: *mut c_char,
    size: c_uint,
) -> c_int {
    match fns().get_dev_product_type {
        // SAFETY: passed on.
        Some(f) => unsafe { f(device, buf, size) },
        None => MISSING,
    }
}

/// # Safety
/// NI's contract.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn DAQmxCreateCOPulseChanFreq(
    handle: TaskHandle,
    counter: *const c_char,
    name: *const c_char,
    units: c_int,
    idle: c_int,
    delay: c_double,
    freq: c_double,
    duty: c_double,
) -> c_int {
    match fns().create_co_pulse_chan_freq {
        // SAFETY: passed on.
        Some(f) => unsafe { f(handle, counter, name, units, idle, delay, freq, duty) },
        None => MISSING,
    }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxCfgImplicitTiming(
    handle: TaskHandle,
    mode: c_int,
    samps: u64,
) -> c_int {
    match fns().cfg_implicit_timing {
        // SAFETY: passed on.
        Some(f) => unsafe { f(handle, mode, samps) },
        None => MISSING,
    }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxCfgDigEdgeStartTrig(
    handle: TaskHandle,
    source: *const c_char,
    edge: c_int,
) -> c_int {
    match fns().cfg_dig_edge_start_trig {
        // SAFETY: passed on.
        Some(f) => unsafe { f(handle, source, edge) },
        None => MISSING,
    }
}

/// # Safety
/// NI's contract.
#[no_mangle]
pub unsafe extern "C" fn DAQmxSetCOPulseTerm(
    handle: TaskHandle,
    channel: *const c_char,
    terminal: *const c_char,
) -> c_int {
    match fns().set_co_pulse_term {
        // SAFETY: passed on.
        Some(f) => unsafe { f(handle, channel, terminal) },
        None => MISSING,
    }
}

/// Pulls (`unplugged` non-zero) or plugs in the cable of device `name`; 0, or -1 if there is no
/// such device.
///
/// # Safety
/// `name` is a NUL-terminated string.
#[no_mangle]
pub unsafe extern "C" fn fringe_fake_nidaqmx_unplug(
    name: *const c_char,
    unplugged: c_int,
) -> c_int {
    fns();
    // SAFETY: the caller promises a NUL-terminated string.
    let name = unsafe { CStr::from_ptr(name) }.to_string_lossy();
    match daqmx_device(&name) {
        Some(d) => {
            d.set_unplugged(unplugged != 0);
            0
        }
        None => -1,
    }
}
