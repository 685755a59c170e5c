//! NI-DAQmx loaded at run time, and its tasks behind safe calls.
//!
//! [`Library::load`] opens `libnidaqmx.so` (a path, else the system's search path) with
//! `libloading` and fills the one table of functions; [`Library::in_process`] takes a table of
//! functions already in the process (the simulated bench's library). Every call's status goes
//! through one check: negative is an error, carried with NI's extended error text; positive is a
//! warning, ignored as NI's own Python API does.

use super::api::{
    self, CfgDigEdgeStartTrig, CfgImplicitTiming, CreateCoPulseChanFreq, Functions, TaskHandle,
    REQUIRED_SYMBOLS,
};
use super::error::{DaqError, DaqmxStatus};
use std::ffi::{c_char, c_int, c_uint, CString};
use std::path::Path;
use std::sync::Arc;

/// The names tried on the system's search path when no path is given: the versioned name NI's
/// packages install, then the development link.
pub(crate) const SEARCH_NAMES: [&str; 2] = ["libnidaqmx.so.1", "libnidaqmx.so"];

/// A loaded NI-DAQmx library.
pub struct Library {
    functions: Functions,
    name: String,
    /// Keeps the shared object mapped while the table is used.
    _loaded: Option<libloading::Library>,
}

impl std::fmt::Debug for Library {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Library").field("name", &self.name).finish()
    }
}

impl Library {
    /// Loads NI-DAQmx from `path`, or from the system's search path ([`SEARCH_NAMES`]).
    pub fn load(path: Option<&Path>) -> Result<Arc<Library>, DaqError> {
        let candidates: Vec<String> = match path {
            Some(p) => vec![p.display().to_string()],
            None => SEARCH_NAMES.iter().map(|s| s.to_string()).collect(),
        };
        let mut reasons = Vec::new();
        for name in &candidates {
            // SAFETY: loading a shared object runs its initialisers; NI-DAQmx (or a library
            // standing in for it) is what the user pointed at.
            match unsafe { libloading::Library::new(name) } {
                Ok(lib) => return Library::from_loaded(lib, name),
                // libloading's own text is only "dlopen failed": the system's reason is its source.
                Err(e) => reasons.push(match std::error::Error::source(&e) {
                    Some(cause) => cause.to_string(),
                    None => e.to_string(),
                }),
            }
        }
        Err(DaqError::LibraryMissing {
            tried: candidates,
            reason: reasons.join("; "),
        })
    }

    fn from_loaded(lib: libloading::Library, name: &str) -> Result<Arc<Library>, DaqError> {
        // SAFETY: the symbols are NI-DAQmx's documented functions, whose C signatures the table
        // declares; the library stays loaded as long as the table (it is kept beside it).
        let functions = unsafe {
            Functions::resolve(|symbol| {
                lib.get::<*const std::ffi::c_void>(symbol.as_bytes())
                    .ok()
                    .map(|s| *s)
            })
        };
        Library::assemble(name, functions, Some(lib))
    }

    /// The library named `name` from its resolved table, keeping `loaded` mapped beside it.
    fn assemble(
        name: &str,
        functions: Result<Functions, &'static str>,
        loaded: Option<libloading::Library>,
    ) -> Result<Arc<Library>, DaqError> {
        let functions = functions.map_err(|missing| DaqError::LibraryIncomplete {
            library: name.to_string(),
            missing: missing.to_string(),
        })?;
        Ok(Arc::new(Library {
            functions,
            name: name.to_string(),
            _loaded: loaded,
        }))
    }

    /// A library whose functions are already in this process, found by `lookup` (the simulated
    /// bench's NI-DAQmx): the same resolver as a loaded library's.
    ///
    /// # Safety
    /// As [`Functions::resolve`]: every address must be the documented function of that name,
    /// valid for the life of the program.
    pub unsafe fn in_process(
        name: &str,
        lookup: impl FnMut(&str) -> Option<*const std::ffi::c_void>,
    ) -> Result<Arc<Library>, DaqError> {
        // SAFETY: passed on from the caller.
        let functions = unsafe { Functions::resolve(lookup) };
        Library::assemble(name, functions, None)
    }

    /// The file or name it was loaded from.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The symbols every NI-DAQmx library must have for the gauge path.
    pub fn required_symbols() -> &'static [&'static str] {
        &REQUIRED_SYMBOLS
    }

    /// NI's description of the last error: the extended error information (the thread's last
    /// error), else the code's text, collapsed to one line.
    fn describe(&self, code: i32) -> String {
        let mut buf = vec![0 as c_char; 4096];
        let f = self.functions;
        // SAFETY: the buffer is writable for its stated size.
        let status = unsafe { (f.get_extended_error_info)(buf.as_mut_ptr(), buf.len() as c_uint) };
        let mut text = if status >= 0 {
            c_text(&buf)
        } else {
            String::new()
        };
        if text.is_empty() {
            if let Some(get) = f.get_error_string {
                buf.fill(0);
                // SAFETY: as above.
                if unsafe { get(code, buf.as_mut_ptr(), buf.len() as c_uint) } >= 0 {
                    text = c_text(&buf);
                }
            }
        }
        let one_line: Vec<&str> = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty() && !l.starts_with("Status Code:"))
            .collect();
        if one_line.is_empty() {
            "NI-DAQmx gave no description".into()
        } else {
            one_line.join(" ")
        }
    }

    /// `Ok` for success or a warning, the error with NI's text otherwise.
    fn check(&self, code: c_int) -> Result<(), DaqmxStatus> {
        if code < 0 {
            Err(DaqmxStatus {
                code,
                text: self.describe(code),
            })
        } else {
            Ok(())
        }
    }

    /// The product type of `device` ("USB-6218"), when the library tells.
    pub fn product_type(&self, device: &str) -> Option<Result<String, DaqmxStatus>> {
        let get = self.functions.get_dev_product_type?;
        let device = CString::new(device).ok()?;
        let mut buf = vec![0 as c_char; 256];
        // SAFETY: NUL-terminated name, writable buffer of the stated size.
        let code = unsafe { get(device.as_ptr(), buf.as_mut_ptr(), buf.len() as c_uint) };
        Some(self.check(code).map(|()| c_text(&buf)))
    }
}

fn c_text(buf: &[c_char]) -> String {
    let bytes: Vec<u8> = buf
        .iter()
        .take_while(|&&c| c != 0)
        .map(|&c| c as u8)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

fn c_string(s: &str) -> Result<CString, DaqmxStatus> {
    CString::new(s).map_err(|_| DaqmxStatus {
        code: 0,
        text: format!("the name {s:?} contains a NUL byte"),
    })
}

/// One NI-DAQmx task, cleared when dropped.
pub(crate) struct Task {
    library: Arc<Library>,
    handle: TaskHandle,
}

// SAFETY: NI-DAQmx is thread-safe (its functions may be called from any thread); the handle is an
// opaque token the library owns, used by one owner at a time here.
unsafe impl Send for Task {}

impl std::fmt::Debug for Task {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Task").finish_non_exhaustive()
    }
}

/// Why a read ended early.
#[derive(Debug)]
pub(crate) struct ReadError {
    /// Scans read before the error (valid at the start of the buffer).
    pub scans: usize,
    pub status: DaqmxStatus,
}

impl Task {
    /// A new unnamed task.
    pub(crate) fn create(library: &Arc<Library>) -> Result<Task, DaqmxStatus> {
        let mut handle: TaskHandle = std::ptr::null_mut();
        let name = c_string("")?;
        // SAFETY: valid string and out pointer.
        let code = unsafe { (library.functions.create_task)(name.as_ptr(), &mut handle) };
        library.check(code)?;
        Ok(Task {
            library: library.clone(),
            handle,
        })
    }

    fn call(&self, code: c_int) -> Result<(), DaqmxStatus> {
        self.library.check(code)
    }

    /// Adds voltage channels `physical` ("Dev1/ai0:5") measured over `min..max` volts.
    pub(crate) fn add_voltage_channels(
        &self,
        physical: &str,
        terminal: c_int,
        min: f64,
        max: f64,
    ) -> Result<(), DaqmxStatus> {
        let physical = c_string(physical)?;
        let empty = c_string("")?;
        let f = self.library.functions.create_ai_voltage_chan;
        // SAFETY: live handle, NUL-terminated strings (a NULL custom scale is documented as
        // none, the empty string too).
        self.call(unsafe {
            f(
                self.handle,
                physical.as_ptr(),
                empty.as_ptr(),
                terminal,
                min,
                max,
                api::VAL_VOLTS,
                std::ptr::null(),
            )
        })
    }

    /// Continuous sampling on the device's own sample clock at `rate` Hz, rising edge;
    /// `buffer` scans per channel (0: NI's default for the rate).
    pub(crate) fn continuous_sample_clock(
        &self,
        rate: f64,
        buffer: u64,
    ) -> Result<(), DaqmxStatus> {
        let source = c_string("")?;
        let f = self.library.functions.cfg_samp_clk_timing;
        // SAFETY: live handle; the empty source is the onboard clock.
        self.call(unsafe {
            f(
                self.handle,
                source.as_ptr(),
                rate,
                api::VAL_RISING,
                api::VAL_CONT_SAMPS,
                buffer,
            )
        })
    }

    /// Sets the input buffer to `scans` per channel, when the library offers it.
    pub(crate) fn input_buffer(&self, scans: u32) -> Result<bool, DaqmxStatus> {
        let Some(f) = self.library.functions.cfg_input_buffer else {
            return Ok(false);
        };
        // SAFETY: live handle.
        self.call(unsafe { f(self.handle, scans) }).map(|()| true)
    }

    /// Reserves and programs the hardware (so a bad channel or rate fails before anything
    /// runs), when the library offers `DAQmxTaskControl`.
    pub(crate) fn commit(&self) -> Result<(), DaqmxStatus> {
        let Some(f) = self.library.functions.task_control else {
            return Ok(());
        };
        // SAFETY: live handle.
        self.call(unsafe { f(self.handle, api::VAL_TASK_COMMIT) })
    }

    pub(crate) fn start(&self) -> Result<(), DaqmxStatus> {
        // SAFETY: live handle.
        self.call(unsafe { (self.library.functions.start_task)(self.handle) })
    }

    pub(crate) fn stop(&self) -> Result<(), DaqmxStatus> {
        // SAFETY: live handle.
        self.call(unsafe { (self.library.functions.stop_task)(self.handle) })
    }

    /// Reads up to `scans` scans of `channels` channels, interleaved by scan, into `out`, waiting
    /// at most `timeout_s`. A timeout with some scans read returns them as an error with the
    /// count, as NI documents.
    pub(crate) fn read(
        &self,
        scans: usize,
        channels: usize,
        timeout_s: f64,
        out: &mut Vec<f64>,
    ) -> Result<usize, ReadError> {
        out.resize(scans * channels, 0.0);
        let mut read: c_int = 0;
        let f = self.library.functions.read_analog_f64;
        // SAFETY: the buffer holds `scans * channels` doubles, as stated.
        let code = unsafe {
            f(
                self.handle,
                scans as c_int,
                timeout_s,
                api::VAL_GROUP_BY_SCAN_NUMBER,
                out.as_mut_ptr(),
                out.len() as c_uint,
                &mut read,
                std::ptr::null_mut(),
            )
        };
        let scans_read = (read.max(0) as usize).min(scans);
        match self.call(code) {
            Ok(()) => Ok(scans_read),
            Err(status) => Err(ReadError {
                scans: scans_read,
                status,
            }),
        }
    }

    /// Scans per channel the device has acquired since the task started, when the library
    /// tells.
    pub(crate) fn total_acquired(&self) -> Option<u64> {
        let f = self
            .library
            .functions
            .get_read_total_samp_per_chan_acquired?;
        let mut n = 0u64;
        // SAFETY: live handle, valid out pointer.
        let code = unsafe { f(self.handle, &mut n) };
        (code >= 0).then_some(n)
    }

    /// A counter output pulsing at `frequency` Hz with `duty` (0..1), idle low, the first pulse
    /// `initial_delay_s` after the task starts, continuously.
    pub(crate) fn add_pulse_train(
        &self,
        counter: &str,
        frequency: f64,
        duty: f64,
        initial_delay_s: f64,
    ) -> Result<(), DaqmxStatus> {
        let f = self.library.functions;
        let (Some(pulse), Some(implicit)): (
            Option<CreateCoPulseChanFreq>,
            Option<CfgImplicitTiming>,
        ) = (f.create_co_pulse_chan_freq, f.cfg_implicit_timing) else {
            return Err(missing(
                "DAQmxCreateCOPulseChanFreq, DAQmxCfgImplicitTiming",
            ));
        };
        let counter = c_string(counter)?;
        let empty = c_string("")?;
        // SAFETY: live handle, NUL-terminated strings.
        self.call(unsafe {
            pulse(
                self.handle,
                counter.as_ptr(),
                empty.as_ptr(),
                api::VAL_HZ,
                api::VAL_LOW,
                initial_delay_s,
                frequency,
                duty,
            )
        })?;
        // SAFETY: live handle. The buffer size is ignored for a continuous pulse train.
        self.call(unsafe { implicit(self.handle, api::VAL_CONT_SAMPS, 1000) })
    }

    /// Routes the pulses of counter channel `counter` to `terminal` ("/Dev1/PFI12").
    pub(crate) fn pulse_terminal(&self, counter: &str, terminal: &str) -> Result<(), DaqmxStatus> {
        let Some(f) = self.library.functions.set_co_pulse_term else {
            return Err(missing("DAQmxSetCOPulseTerm"));
        };
        let (counter, terminal) = (c_string(counter)?, c_string(terminal)?);
        // SAFETY: live handle, NUL-terminated strings.
        self.call(unsafe { f(self.handle, counter.as_ptr(), terminal.as_ptr()) })
    }

    /// Starts the task on the rising edge of `source` ("/Dev1/ai/StartTrigger").
    pub(crate) fn start_on_edge(&self, source: &str) -> Result<(), DaqmxStatus> {
        let Some(f): Option<CfgDigEdgeStartTrig> = self.library.functions.cfg_dig_edge_start_trig
        else {
            return Err(missing("DAQmxCfgDigEdgeStartTrig"));
        };
        let source = c_string(source)?;
        // SAFETY: live handle, NUL-terminated string.
        self.call(unsafe { f(self.handle, source.as_ptr(), api::VAL_RISING) })
    }
}

fn missing(functions: &str) -> DaqmxStatus {
    DaqmxStatus {
        code: 0,
        text: format!(
            "this NI-DAQmx library has no {functions}, which triggering the camera needs"
        ),
    }
}

impl Drop for Task {
    fn drop(&mut self) {
        // SAFETY: the handle is live until here and not used after.
        unsafe {
            (self.library.functions.clear_task)(self.handle);
        }
    }
}
