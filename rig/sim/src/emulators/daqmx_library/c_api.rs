//! The simulated library's C functions, with NI's signatures, over a process-wide registry of
//! devices and tasks; and the lookup that gives them to the driver's resolver by NI's names.
//!
//! The last error of each thread is kept for `DAQmxGetExtendedErrorInfo`, as NI keeps it.

use super::device::SimDevice;
use super::task::{AiChannel, CoChannel, SimTask};
use super::texts::{description, Fault, INVALID_ATTRIBUTE_VALUE, INVALID_TASK};
use fringe_rig::nidaqmx;
use fringe_rig::nidaqmx::TaskHandle;
use std::cell::RefCell;
use std::collections::HashMap;
use std::ffi::{c_char, c_double, c_int, c_uint, c_void, CStr};
use std::sync::{Arc, Mutex, MutexGuard, OnceLock};

#[derive(Default)]
struct Registry {
    devices: HashMap<String, Arc<SimDevice>>,
    tasks: HashMap<usize, Arc<Mutex<SimTask>>>,
    next_handle: usize,
    unnamed: usize,
}

fn registry() -> MutexGuard<'static, Registry> {
    static REGISTRY: OnceLock<Mutex<Registry>> = OnceLock::new();
    REGISTRY
        .get_or_init(Mutex::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner())
}

thread_local! {
    static LAST_ERROR: RefCell<String> = const { RefCell::new(String::new()) };
}

/// Puts `device` on the simulated bus (replacing one of the same name).
pub fn install(device: Arc<SimDevice>) {
    registry().devices.insert(device.name.clone(), device);
}

/// Takes the device named `name` off the bus.
pub(crate) fn remove(name: &str) {
    registry().devices.remove(name);
}

/// The device named `name`, if installed.
pub fn device(name: &str) -> Option<Arc<SimDevice>> {
    registry().devices.get(name).cloned()
}

fn task(handle: TaskHandle) -> Result<Arc<Mutex<SimTask>>, Fault> {
    registry()
        .tasks
        .get(&(handle as usize))
        .cloned()
        .ok_or_else(|| Fault::new(INVALID_TASK, &[]))
}

fn lock(t: &Mutex<SimTask>) -> MutexGuard<'_, SimTask> {
    t.lock().unwrap_or_else(|e| e.into_inner())
}

/// Returns 0, or records `fault` as this thread's last error and returns its code.
fn report(task_name: &str, r: Result<(), Fault>) -> c_int {
    match r {
        Ok(()) => 0,
        Err(f) => {
            let code = if f.code == 0 { -200000 } else { f.code };
            LAST_ERROR.with(|e| *e.borrow_mut() = f.extended(task_name));
            code
        }
    }
}

fn with_task(handle: TaskHandle, f: impl FnOnce(&mut SimTask) -> Result<(), Fault>) -> c_int {
    match task(handle) {
        Ok(t) => {
            let mut t = lock(&t);
            let r = f(&mut t);
            let name = t.name.clone();
            report(&name, r)
        }
        Err(fault) => report("", Err(fault)),
    }
}

/// # Safety
/// `s` is NULL or a NUL-terminated string.
unsafe fn text(s: *const c_char) -> String {
    if s.is_null() {
        String::new()
    } else {
        // SAFETY: the caller promises a NUL-terminated string.
        unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned()
    }
}

fn copy_out(s: &str, buf: *mut c_char, size: c_uint) -> c_int {
    let bytes = s.as_bytes();
    if buf.is_null() || size == 0 {
        // NI returns the size needed when given no buffer.
        return bytes.len() as c_int + 1;
    }
    let n = bytes.len().min(size as usize - 1);
    // SAFETY: the caller gave a buffer of `size` bytes; n + 1 <= size.
    unsafe {
        std::ptr::copy_nonoverlapping(bytes.as_ptr() as *const c_char, buf, n);
        *buf.add(n) = 0;
    }
    0
}

/// Splits "Dev1/ai0:5" into the device and the channel numbers of prefix `kind` ("ai", "ctr").
fn physical(list: &str, kind: &str) -> Result<Vec<(Arc<SimDevice>, u32)>, Fault> {
    let mut out = Vec::new();
    for part in list.split(',').map(str::trim) {
        let part = part.trim_start_matches('/');
        let Some((dev, chan)) = part.split_once('/') else {
            return Err(Fault::new(
                nidaqmx::PHYSICAL_CHAN_DOES_NOT_EXIST,
                &[format!("Physical Channel Name: {part}")],
            ));
        };
        let device = device(dev).ok_or_else(|| {
            let known: Vec<String> = registry().devices.keys().cloned().collect();
            Fault::new(
                nidaqmx::INVALID_DEVICE_ID,
                &[
                    format!("Device Specified: {dev}"),
                    format!("Suggested Device(s): {}", known.join(", ")),
                ],
            )
        })?;
        if device.unplugged() {
            return Err(Fault::new(
                nidaqmx::DEV_CANNOT_BE_ACCESSED,
                &[format!("Device: {dev}")],
            ));
        }
        let no_channel = || {
            Fault::new(
                nidaqmx::PHYSICAL_CHAN_DOES_NOT_EXIST,
                &[
                    format!("Device: {dev}"),
                    format!("Physical Channel Name: {chan}"),
                ],
            )
        };
        let span = chan.strip_prefix(kind).ok_or_else(no_channel)?;
        let number = |s: &str| {
            s.strip_prefix(kind)
                .unwrap_or(s)
                .parse::<u32>()
                .map_err(|_| no_channel())
        };
        let (a, b) = match span.split_once(':') {
            Some((a, b)) => (number(a)?, number(b)?),
            None => (number(span)?, number(span)?),
        };
        let count = if kind == "ai" {
            device.model.ai_channels
        } else {
            device.model.counters
        };
        let numbers: Vec<u32> = if a <= b {
            (a..=b).collect()
        } else {
            (b..=a).rev().collect()
        };
        for n in numbers {
            if n >= count {
                return Err(no_channel());
            }
            out.push((device.clone(), n));
        }
    }
    Ok(out)
}

extern "C" fn create_task(name: *const c_char, handle: *mut TaskHandle) -> c_int {
    // SAFETY: NI's contract: a NUL-terminated name (or NULL).
    let mut name = unsafe { text(name) };
    let mut reg = registry();
    if name.is_empty() {
        name = format!("_unnamedTask<{}>", reg.unnamed);
        reg.unnamed += 1;
    }
    reg.next_handle += 1;
    let h = reg.next_handle;
    reg.tasks
        .insert(h, Arc::new(Mutex::new(SimTask::named(name))));
    if !handle.is_null() {
        // SAFETY: NI's contract: a writable TaskHandle.
        unsafe { *handle = h as TaskHandle };
    }
    0
}

extern "C" fn start_task(handle: TaskHandle) -> c_int {
    with_task(handle, |t| t.start())
}

extern "C" fn stop_task(handle: TaskHandle) -> c_int {
    with_task(handle, |t| {
        t.stop();
        Ok(())
    })
}

extern "C" fn clear_task(handle: TaskHandle) -> c_int {
    let removed = registry().tasks.remove(&(handle as usize));
    match removed {
        Some(t) => {
            lock(&t).stop();
            0
        }
        None => report("", Err(Fault::new(INVALID_TASK, &[]))),
    }
}

extern "C" fn task_control(handle: TaskHandle, action: c_int) -> c_int {
    with_task(handle, |t| match action {
        nidaqmx::VAL_TASK_COMMIT | 2 | 4 => t.verify(),
        0 => t.start(),
        1 | 6 => {
            t.stop();
            Ok(())
        }
        _ => Ok(()),
    })
}

#[allow(clippy::too_many_arguments)]
extern "C" fn create_ai_voltage_chan(
    handle: TaskHandle,
    channel: *const c_char,
    _name: *const c_char,
    terminal: c_int,
    min: c_double,
    max: c_double,
    units: c_int,
    _scale: *const c_char,
) -> c_int {
    // SAFETY: NI's contract: NUL-terminated strings.
    let channel = unsafe { text(channel) };
    with_task(handle, |t| {
        if units != nidaqmx::VAL_VOLTS {
            return Err(Fault::new(
                INVALID_ATTRIBUTE_VALUE,
                &[
                    "Property: DAQmx_AI_Voltage_Units".into(),
                    format!("Requested Value: {units}"),
                ],
            ));
        }
        for (device, number) in physical(&channel, "ai")? {
            if terminal == nidaqmx::VAL_DIFF && !device.model.differential_positive(number) {
                return Err(Fault::new(
                    nidaqmx::PHYSICAL_CHAN_DOES_NOT_EXIST,
                    &[
                        format!("Device: {}", device.name),
                        format!("Physical Channel Name: ai{number}"),
                        "A differential channel is named by its positive input (ai0-ai7, ai16-ai23).".into(),
                    ],
                ));
            }
            if ![
                nidaqmx::VAL_DIFF,
                nidaqmx::VAL_RSE,
                nidaqmx::VAL_NRSE,
                nidaqmx::VAL_CFG_DEFAULT,
            ]
            .contains(&terminal)
            {
                return Err(Fault::new(
                    INVALID_ATTRIBUTE_VALUE,
                    &[
                        "Property: DAQmx_AI_TermCfg".into(),
                        format!("Requested Value: {terminal}"),
                    ],
                ));
            }
            let range = device
                .model
                .range_for(min, max)
                .filter(|_| min < max)
                .ok_or_else(|| {
                    Fault::new(
                        INVALID_ATTRIBUTE_VALUE,
                        &[
                            "Property: DAQmx_AI_Max".into(),
                            format!("Requested Value: {max}"),
                            format!("Minimum Value: {min}"),
                            format!("Device: {}", device.name),
                        ],
                    )
                })?;
            t.ai.push(AiChannel {
                device,
                number,
                range,
            });
        }
        Ok(())
    })
}

extern "C" fn cfg_samp_clk_timing(
    handle: TaskHandle,
    _source: *const c_char,
    rate: c_double,
    _edge: c_int,
    mode: c_int,
    samps: u64,
) -> c_int {
    with_task(handle, |t| {
        if mode != nidaqmx::VAL_CONT_SAMPS {
            return Err(Fault::new(
                INVALID_ATTRIBUTE_VALUE,
                &[
                    "Property: DAQmx_SampQuant_SampMode".into(),
                    format!("Requested Value: {mode}"),
                    "The simulated library acquires continuously only.".into(),
                ],
            ));
        }
        if !(rate.is_finite() && rate > 0.0) {
            return Err(Fault::new(
                INVALID_ATTRIBUTE_VALUE,
                &[
                    "Property: DAQmx_SampClk_Rate".into(),
                    format!("Requested Value: {rate}"),
                ],
            ));
        }
        t.rate_hz = Some(rate);
        t.samps_per_chan = samps;
        Ok(())
    })
}

extern "C" fn cfg_input_buffer(handle: TaskHandle, scans: c_uint) -> c_int {
    with_task(handle, |t| {
        t.input_buffer = Some(u64::from(scans));
        Ok(())
    })
}

#[allow(clippy::too_many_arguments)]
extern "C" fn read_analog_f64(
    handle: TaskHandle,
    num: c_int,
    timeout: c_double,
    fill_mode: c_uint,
    array: *mut c_double,
    size: c_uint,
    read: *mut c_int,
    _reserved: *mut c_uint,
) -> c_int {
    let out: &mut [f64] = if array.is_null() || size == 0 {
        &mut []
    } else {
        // SAFETY: NI's contract: `array` holds `size` doubles.
        unsafe { std::slice::from_raw_parts_mut(array, size as usize) }
    };
    let mut scans = 0usize;
    let code = with_task(handle, |t| {
        let (n, r) = t.read(num, timeout, fill_mode, out);
        scans = n;
        r
    });
    if !read.is_null() {
        // SAFETY: NI's contract: a writable int32.
        unsafe { *read = scans as c_int };
    }
    code
}

extern "C" fn get_read_total_samp_per_chan_acquired(handle: TaskHandle, data: *mut u64) -> c_int {
    with_task(handle, |t| {
        let n = t.total_acquired()?;
        if !data.is_null() {
            // SAFETY: NI's contract: a writable uInt64.
            unsafe { *data = n };
        }
        Ok(())
    })
}

extern "C" fn get_extended_error_info(buf: *mut c_char, size: c_uint) -> c_int {
    LAST_ERROR.with(|e| copy_out(&e.borrow(), buf, size))
}

extern "C" fn get_error_string(code: c_int, buf: *mut c_char, size: c_uint) -> c_int {
    copy_out(description(code), buf, size)
}

extern "C" fn get_dev_product_type(dev: *const c_char, buf: *mut c_char, size: c_uint) -> c_int {
    // SAFETY: NI's contract: a NUL-terminated name.
    let name = unsafe { text(dev) };
    match device(&name) {
        Some(d) => copy_out(&d.model.product, buf, size),
        None => report(
            "",
            Err(Fault::new(
                nidaqmx::INVALID_DEVICE_ID,
                &[format!("Device Specified: {name}")],
            )),
        ),
    }
}

#[allow(clippy::too_many_arguments)]
extern "C" fn create_co_pulse_chan_freq(
    handle: TaskHandle,
    counter: *const c_char,
    _name: *const c_char,
    units: c_int,
    _idle: c_int,
    delay: c_double,
    freq: c_double,
    duty: c_double,
) -> c_int {
    // SAFETY: NI's contract: NUL-terminated strings.
    let counter = unsafe { text(counter) };
    with_task(handle, |t| {
        let mut found = physical(&counter, "ctr")?;
        if found.len() != 1
            || units != nidaqmx::VAL_HZ
            || !(freq.is_finite() && freq > 0.0 && duty > 0.0 && duty < 1.0)
        {
            return Err(Fault::new(
                INVALID_ATTRIBUTE_VALUE,
                &[
                    "Property: DAQmx_CO_Pulse_Freq".into(),
                    format!("Requested Value: {freq}"),
                    format!("Duty cycle: {duty}"),
                ],
            ));
        }
        let (device, _) = found.remove(0);
        t.co = Some(CoChannel {
            device,
            frequency_hz: freq,
            initial_delay_s: delay.max(0.0),
            terminal: None,
            start_trigger: None,
        });
        Ok(())
    })
}

extern "C" fn cfg_implicit_timing(handle: TaskHandle, _mode: c_int, _samps: u64) -> c_int {
    with_task(handle, |_| Ok(()))
}

extern "C" fn cfg_dig_edge_start_trig(
    handle: TaskHandle,
    source: *const c_char,
    _edge: c_int,
) -> c_int {
    // SAFETY: NI's contract: a NUL-terminated string.
    let source = unsafe { text(source) };
    with_task(handle, |t| {
        match &mut t.co {
            Some(co) => co.start_trigger = Some(source),
            None => {
                return Err(Fault::new(
                    INVALID_ATTRIBUTE_VALUE,
                    &["The simulated library triggers counter outputs only.".into()],
                ))
            }
        }
        Ok(())
    })
}

extern "C" fn set_co_pulse_term(
    handle: TaskHandle,
    _channel: *const c_char,
    terminal: *const c_char,
) -> c_int {
    // SAFETY: NI's contract: a NUL-terminated string.
    let terminal = unsafe { text(terminal) };
    with_task(handle, |t| match &mut t.co {
        Some(co) => {
            co.terminal = Some(terminal);
            Ok(())
        }
        None => Err(Fault::new(
            INVALID_ATTRIBUTE_VALUE,
            &["Property: DAQmx_CO_Pulse_Term".into()],
        )),
    })
}

/// The simulated library's function of NI's name `symbol`, for
/// [`fringe_rig::nidaqmx::Library::in_process`] or a shared object's exports.
pub fn lookup(symbol: &str) -> Option<*const c_void> {
    let f: *const c_void = match symbol {
        "DAQmxCreateTask" => create_task as nidaqmx::CreateTask as *const c_void,
        "DAQmxStartTask" => start_task as nidaqmx::TaskFn as *const c_void,
        "DAQmxStopTask" => stop_task as nidaqmx::TaskFn as *const c_void,
        "DAQmxClearTask" => clear_task as nidaqmx::TaskFn as *const c_void,
        "DAQmxTaskControl" => task_control as nidaqmx::TaskControl as *const c_void,
        "DAQmxCreateAIVoltageChan" => {
            create_ai_voltage_chan as nidaqmx::CreateAiVoltageChan as *const c_void
        }
        "DAQmxCfgSampClkTiming" => {
            cfg_samp_clk_timing as nidaqmx::CfgSampClkTiming as *const c_void
        }
        "DAQmxCfgInputBuffer" => cfg_input_buffer as nidaqmx::CfgInputBuffer as *const c_void,
        "DAQmxReadAnalogF64" => read_analog_f64 as nidaqmx::ReadAnalogF64 as *const c_void,
        "DAQmxGetReadTotalSampPerChanAcquired" => {
            get_read_total_samp_per_chan_acquired as nidaqmx::GetU64 as *const c_void
        }
        "DAQmxGetExtendedErrorInfo" => {
            get_extended_error_info as nidaqmx::GetExtendedErrorInfo as *const c_void
        }
        "DAQmxGetErrorString" => get_error_string as nidaqmx::GetErrorString as *const c_void,
        "DAQmxGetDevProductType" => {
            get_dev_product_type as nidaqmx::GetDevProductType as *const c_void
        }
        "DAQmxCreateCOPulseChanFreq" => {
            create_co_pulse_chan_freq as nidaqmx::CreateCoPulseChanFreq as *const c_void
        }
        "DAQmxCfgImplicitTiming" => {
            cfg_implicit_timing as nidaqmx::CfgImplicitTiming as *const c_void
        }
        "DAQmxCfgDigEdgeStartTrig" => {
            cfg_dig_edge_start_trig as nidaqmx::CfgDigEdgeStartTrig as *const c_void
        }
        "DAQmxSetCOPulseTerm" => set_co_pulse_term as nidaqmx::SetCoPulseTerm as *const c_void,
        _ => return None,
    };
    Some(f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emulators::daqmx_library::{DaqSignals, DeviceModel, DeviceTiming};
    use fringe_rig::atical::GaugeSource;
    use fringe_rig::nidaqmx::{CameraTrigger, DaqSettings, Library, NiDaq};
    use fringe_rig::Hertz;
    use fringe_rig::HostTime;
    use std::sync::mpsc;
    use std::time::Duration;

    /// Reports the sample clock's start.
    struct Started(mpsc::Sender<HostTime>);

    impl DaqSignals for Started {
        fn scan(&mut self, _: u64, _: HostTime, _: &[u32], out: &mut [f64]) {
            out.fill(0.0);
        }
        fn started(&mut self, start: HostTime, _: f64, _: f64) {
            let _ = self.0.send(start);
        }
    }

    fn library() -> Arc<Library> {
        // SAFETY: `lookup` gives this module's functions, with NI's signatures.
        unsafe { Library::in_process("simulated", lookup) }.expect("the simulated library")
    }

    #[test]
    fn the_camera_trigger_starts_on_the_analogue_start_edge() {
        let (tx, rx) = mpsc::channel();
        let device = SimDevice::new(
            "TrigTest1",
            DeviceModel::usb_6218(),
            DeviceTiming {
                clock_drift_ppm: 30.0,
                ..DeviceTiming::default()
            },
            Box::new(Started(tx)),
        );
        install(device.clone());
        let lib = library();
        let settings = DaqSettings {
            device: "TrigTest1".into(),
            ..DaqSettings::default()
        };
        let trigger = CameraTrigger {
            counter: "ctr0".into(),
            terminal: Some("PFI12".into()),
            frame_rate: Hertz(50.0),
            duty: 0.5,
        };
        let mut daq = NiDaq::open(&lib, settings)
            .and_then(|d| d.with_camera_trigger(&lib, trigger.clone()))
            .expect("open with the trigger");
        assert_eq!(
            device.pulses(),
            None,
            "armed, not running, before the start"
        );
        daq.start().expect("start");
        let start = rx
            .recv_timeout(Duration::from_secs(1))
            .expect("the clock's start");
        let pulses = device.pulses().expect("pulsing after the analogue start");
        assert_eq!(pulses.first, start, "pulse 0 on scan 0");
        // Pulse 50 is one second of the DAQ's (drifting) clock later: scan 5000.
        let period = 1e9 / (5000.0 * (1.0 + 30e-6));
        let scan_5000 = start.0 as f64 + 5000.0 * period;
        assert!((pulses.edge(50).0 as f64 - scan_5000).abs() < 1.0);
        assert_eq!(trigger.pulse_scan(50, Hertz(5000.0)), 5000.0);
        daq.stop().expect("stop");
        assert_eq!(
            device.pulses(),
            None,
            "the counter stops with the acquisition"
        );
        drop(daq);
        remove("TrigTest1");
    }

    #[test]
    fn a_second_acquisition_on_a_busy_device_is_refused_as_reserved() {
        install(SimDevice::new(
            "Busy1",
            DeviceModel::usb_6218(),
            DeviceTiming::default(),
            Box::new(|_: u64, _: HostTime, _: &[u32], out: &mut [f64]| out.fill(0.0)),
        ));
        let lib = library();
        let settings = DaqSettings {
            device: "Busy1".into(),
            ..DaqSettings::default()
        };
        let mut first = NiDaq::open(&lib, settings.clone()).expect("first");
        first.start().expect("start the first");
        let mut second = NiDaq::open(&lib, settings).expect("configuring is allowed");
        let e = second.start().expect_err("the device is busy");
        assert!(e.to_string().contains("in use by another task"), "{e}");
        first.stop().expect("stop");
        second.start().expect("free again");
        remove("Busy1");
    }
}
