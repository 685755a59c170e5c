//! The part of NI-DAQmx's C API the driver calls: one table of C functions, its documented
//! constants and status codes.
//!
//! Every signature and value is declared here from NI's documentation (`NIDAQmx.h` and the NI-DAQmx
//! help; `docs/nidaqmx.md` lists which fact comes from where). On Linux x86-64 `int32` is a C
//! `int`, `uInt32` an `unsigned int`, `bool32` an `unsigned int`, `float64` a `double` and a
//! `TaskHandle` a `void*`; the calling convention is plain C.
//!
//! The table is filled by one resolver, [`Functions::resolve`], from a symbol lookup: the loaded
//! `libnidaqmx.so` in production and in the tests (a fake library built in the workspace), or a
//! table of functions in the same process (the simulated bench's library).

use std::ffi::{c_char, c_double, c_int, c_uint, c_void};

/// NI's `TaskHandle`.
pub type TaskHandle = *mut c_void;

/// `int32 DAQmxCreateTask(const char taskName[], TaskHandle *taskHandle)`.
pub type CreateTask = unsafe extern "C" fn(*const c_char, *mut TaskHandle) -> c_int;
/// `DAQmxStartTask`, `DAQmxStopTask`, `DAQmxClearTask`: `int32 f(TaskHandle)`.
pub type TaskFn = unsafe extern "C" fn(TaskHandle) -> c_int;
/// `int32 DAQmxTaskControl(TaskHandle, int32 action)`.
pub type TaskControl = unsafe extern "C" fn(TaskHandle, c_int) -> c_int;
/// `int32 DAQmxCreateAIVoltageChan(TaskHandle, const char physicalChannel[], const char
/// nameToAssignToChannel[], int32 terminalConfig, float64 minVal, float64 maxVal, int32 units,
/// const char customScaleName[])`.
pub type CreateAiVoltageChan = unsafe extern "C" fn(
    TaskHandle,
    *const c_char,
    *const c_char,
    c_int,
    c_double,
    c_double,
    c_int,
    *const c_char,
) -> c_int;
/// `int32 DAQmxCfgSampClkTiming(TaskHandle, const char source[], float64 rate, int32 activeEdge,
/// int32 sampleMode, uInt64 sampsPerChan)`.
pub type CfgSampClkTiming =
    unsafe extern "C" fn(TaskHandle, *const c_char, c_double, c_int, c_int, u64) -> c_int;
/// `int32 DAQmxCfgInputBuffer(TaskHandle, uInt32 numSampsPerChan)`.
pub type CfgInputBuffer = unsafe extern "C" fn(TaskHandle, c_uint) -> c_int;
/// `int32 DAQmxReadAnalogF64(TaskHandle, int32 numSampsPerChan, float64 timeout, bool32 fillMode,
/// float64 readArray[], uInt32 arraySizeInSamps, int32 *sampsPerChanRead, bool32 *reserved)`.
pub type ReadAnalogF64 = unsafe extern "C" fn(
    TaskHandle,
    c_int,
    c_double,
    c_uint,
    *mut c_double,
    c_uint,
    *mut c_int,
    *mut c_uint,
) -> c_int;
/// `int32 DAQmxGetReadTotalSampPerChanAcquired(TaskHandle, uInt64 *data)`.
pub type GetU64 = unsafe extern "C" fn(TaskHandle, *mut u64) -> c_int;
/// `int32 DAQmxGetExtendedErrorInfo(char errorString[], uInt32 bufferSize)`.
pub type GetExtendedErrorInfo = unsafe extern "C" fn(*mut c_char, c_uint) -> c_int;
/// `int32 DAQmxGetErrorString(int32 errorCode, char errorString[], uInt32 bufferSize)`.
pub type GetErrorString = unsafe extern "C" fn(c_int, *mut c_char, c_uint) -> c_int;
/// `int32 DAQmxGetDevProductType(const char device[], char *data, uInt32 bufferSize)`.
pub type GetDevProductType = unsafe extern "C" fn(*const c_char, *mut c_char, c_uint) -> c_int;
/// `int32 DAQmxCreateCOPulseChanFreq(TaskHandle, const char counter[], const char
/// nameToAssignToChannel[], int32 units, int32 idleState, float64 initialDelay, float64 freq,
/// float64 dutyCycle)`.
pub type CreateCoPulseChanFreq = unsafe extern "C" fn(
    TaskHandle,
    *const c_char,
    *const c_char,
    c_int,
    c_int,
    c_double,
    c_double,
    c_double,
) -> c_int;
/// `int32 DAQmxCfgImplicitTiming(TaskHandle, int32 sampleMode, uInt64 sampsPerChan)`.
pub type CfgImplicitTiming = unsafe extern "C" fn(TaskHandle, c_int, u64) -> c_int;
/// `int32 DAQmxCfgDigEdgeStartTrig(TaskHandle, const char triggerSource[], int32 triggerEdge)`.
pub type CfgDigEdgeStartTrig = unsafe extern "C" fn(TaskHandle, *const c_char, c_int) -> c_int;
/// `int32 DAQmxSetCOPulseTerm(TaskHandle, const char channel[], const char *data)`.
pub type SetCoPulseTerm = unsafe extern "C" fn(TaskHandle, *const c_char, *const c_char) -> c_int;

/// `DAQmx_Val_Cfg_Default`.
pub const VAL_CFG_DEFAULT: c_int = -1;
/// Terminal configurations (`DAQmx_Val_RSE`, `NRSE`, `Diff`, `PseudoDiff`).
pub const VAL_RSE: c_int = 10083;
pub const VAL_NRSE: c_int = 10078;
pub const VAL_DIFF: c_int = 10106;
pub(crate) const VAL_PSEUDO_DIFF: c_int = 12529;
/// `DAQmx_Val_Volts`.
pub const VAL_VOLTS: c_int = 10348;
/// `DAQmx_Val_Rising`.
pub(crate) const VAL_RISING: c_int = 10280;
/// `DAQmx_Val_ContSamps`.
pub const VAL_CONT_SAMPS: c_int = 10123;
/// `DAQmx_Val_GroupByScanNumber` (interleaved: ch0 ch1 .. chN-1, ch0 ...).
pub const VAL_GROUP_BY_SCAN_NUMBER: c_uint = 1;
/// `DAQmx_Val_Hz`.
pub const VAL_HZ: c_int = 10373;
/// `DAQmx_Val_Low` (a counter output's idle state).
pub(crate) const VAL_LOW: c_int = 10214;
/// `DAQmx_Val_Task_Commit` (a `DAQmxTaskControl` action: reserve and program the hardware).
pub const VAL_TASK_COMMIT: c_int = 3;

/// Status codes the driver acts on (`NIDAQmx.h`; 0 success, negative error, positive warning).
pub(crate) mod status {
    /// `DAQmxErrorSamplesNoLongerAvailable`: the reader fell behind the circular buffer.
    pub const SAMPLES_NO_LONGER_AVAILABLE: i32 = -200279;
    /// `DAQmxErrorSamplesNotYetAvailable`: a read's timeout elapsed (partial data returned).
    pub const SAMPLES_NOT_YET_AVAILABLE: i32 = -200284;
    /// `DAQmxErrorInputFIFOOverflow2`: the device's own memory overflowed.
    pub(crate) const INPUT_FIFO_OVERFLOW: i32 = -200361;
    /// `DAQmxErrorInvalidDeviceID`.
    pub const INVALID_DEVICE_ID: i32 = -200220;
    /// `DAQmxErrorPhysicalChanDoesNotExist`.
    pub const PHYSICAL_CHAN_DOES_NOT_EXIST: i32 = -200170;
    /// `DAQmxErrorDevCannotBeAccessed`.
    pub const DEV_CANNOT_BE_ACCESSED: i32 = -201003;
    /// `DAQmxErrorDriverDeviceGUIDNotFound_Routing`.
    pub(crate) const DEVICE_NOT_FOUND_ROUTING: i32 = -88705;
    /// `DAQmxErrorPALTransferAborted`.
    pub(crate) const TRANSFER_ABORTED: i32 = -50405;
    /// `DAQmxErrorDevAbsentOrUnavailable`.
    pub(crate) const DEV_ABSENT_OR_UNAVAILABLE: i32 = -200324;
    /// `DAQmxErrorDeviceRemoved`.
    pub(crate) const DEVICE_REMOVED: i32 = -200045;
    /// `DAQmxErrorPALResourceReserved`: another task holds the device's resources.
    pub const RESOURCE_RESERVED: i32 = -50103;

    /// Whether `code` is one of the codes reported for a device that went away (a pulled USB
    /// cable, power lost): which one a USB-6218 returns is not documented, so all count.
    pub(crate) fn device_lost(code: i32) -> bool {
        matches!(
            code,
            DEV_CANNOT_BE_ACCESSED
                | DEVICE_NOT_FOUND_ROUTING
                | TRANSFER_ABORTED
                | DEV_ABSENT_OR_UNAVAILABLE
                | DEVICE_REMOVED
        )
    }
}

/// The NI-DAQmx functions the driver calls. The gauge path needs the required ones; the rest are
/// used when the library has them (`None` otherwise) or, for the counter output, when the
/// camera is triggered by the DAQ.
#[derive(Clone, Copy)]
pub struct Functions {
    pub create_task: CreateTask,
    pub start_task: TaskFn,
    pub stop_task: TaskFn,
    pub clear_task: TaskFn,
    pub create_ai_voltage_chan: CreateAiVoltageChan,
    pub cfg_samp_clk_timing: CfgSampClkTiming,
    pub read_analog_f64: ReadAnalogF64,
    pub get_extended_error_info: GetExtendedErrorInfo,
    pub task_control: Option<TaskControl>,
    pub cfg_input_buffer: Option<CfgInputBuffer>,
    pub get_read_total_samp_per_chan_acquired: Option<GetU64>,
    pub get_error_string: Option<GetErrorString>,
    pub get_dev_product_type: Option<GetDevProductType>,
    pub create_co_pulse_chan_freq: Option<CreateCoPulseChanFreq>,
    pub cfg_implicit_timing: Option<CfgImplicitTiming>,
    pub cfg_dig_edge_start_trig: Option<CfgDigEdgeStartTrig>,
    pub set_co_pulse_term: Option<SetCoPulseTerm>,
}

/// The symbols [`Functions::resolve`] looks up, required ones first.
pub(crate) const REQUIRED_SYMBOLS: [&str; 8] = [
    "DAQmxCreateTask",
    "DAQmxStartTask",
    "DAQmxStopTask",
    "DAQmxClearTask",
    "DAQmxCreateAIVoltageChan",
    "DAQmxCfgSampClkTiming",
    "DAQmxReadAnalogF64",
    "DAQmxGetExtendedErrorInfo",
];

impl Functions {
    /// Fills the table from `lookup` (a symbol name to its address, `None` when absent). Fails
    /// with the name of the first required function that is missing.
    ///
    /// # Safety
    /// Every address `lookup` returns must be a function with the C signature NI documents for
    /// that name, valid for as long as the table is used.
    pub unsafe fn resolve(
        mut lookup: impl FnMut(&str) -> Option<*const c_void>,
    ) -> Result<Functions, &'static str> {
        macro_rules! required {
            ($name:literal, $ty:ty) => {
                match lookup($name) {
                    // SAFETY: the caller promises the address is this documented function.
                    Some(p) if !p.is_null() => unsafe {
                        std::mem::transmute::<*const c_void, $ty>(p)
                    },
                    _ => return Err($name),
                }
            };
        }
        macro_rules! optional {
            ($name:literal, $ty:ty) => {
                match lookup($name) {
                    // SAFETY: as above.
                    Some(p) if !p.is_null() => {
                        Some(unsafe { std::mem::transmute::<*const c_void, $ty>(p) })
                    }
                    _ => None,
                }
            };
        }
        Ok(Functions {
            create_task: required!("DAQmxCreateTask", CreateTask),
            start_task: required!("DAQmxStartTask", TaskFn),
            stop_task: required!("DAQmxStopTask", TaskFn),
            clear_task: required!("DAQmxClearTask", TaskFn),
            create_ai_voltage_chan: required!("DAQmxCreateAIVoltageChan", CreateAiVoltageChan),
            cfg_samp_clk_timing: required!("DAQmxCfgSampClkTiming", CfgSampClkTiming),
            read_analog_f64: required!("DAQmxReadAnalogF64", ReadAnalogF64),
            get_extended_error_info: required!("DAQmxGetExtendedErrorInfo", GetExtendedErrorInfo),
            task_control: optional!("DAQmxTaskControl", TaskControl),
            cfg_input_buffer: optional!("DAQmxCfgInputBuffer", CfgInputBuffer),
            get_read_total_samp_per_chan_acquired: optional!(
                "DAQmxGetReadTotalSampPerChanAcquired",
                GetU64
            ),
            get_error_string: optional!("DAQmxGetErrorString", GetErrorString),
            get_dev_product_type: optional!("DAQmxGetDevProductType", GetDevProductType),
            create_co_pulse_chan_freq: optional!(
                "DAQmxCreateCOPulseChanFreq",
                CreateCoPulseChanFreq
            ),
            cfg_implicit_timing: optional!("DAQmxCfgImplicitTiming", CfgImplicitTiming),
            cfg_dig_edge_start_trig: optional!("DAQmxCfgDigEdgeStartTrig", CfgDigEdgeStartTrig),
            set_co_pulse_term: optional!("DAQmxSetCOPulseTerm", SetCoPulseTerm),
        })
    }
}
