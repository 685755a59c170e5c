//! NI-DAQmx data acquisition devices (the reference bench's NI USB-6218) reading an ATI
//! transducer's six gauges and the camera's exposure strobe, and triggering the camera.
//!
//! - [`api`]: the C functions and constants used, one table filled by one resolver.
//! - [`library`]: `libnidaqmx.so` loaded at run time (nothing from NI at build time) and its
//!   tasks behind safe calls.
//! - [`settings`]: device, channels, terminal configuration, range, rate; the camera trigger.
//! - [`gauges`]: [`NiDaq`], a [`crate::atical::GaugeSource`] for the `.cal` path.
//! - [`error`]: errors sorted by the setting to change.
//!
//! Which documented facts the driver relies on, and where NI documents them, is listed in
//! `docs/nidaqmx.md`.

pub(crate) mod api;
pub(crate) mod error;
pub(crate) mod gauges;
pub(crate) mod library;
pub(crate) mod settings;

pub use api::status::{
    DEV_CANNOT_BE_ACCESSED, INVALID_DEVICE_ID, PHYSICAL_CHAN_DOES_NOT_EXIST, RESOURCE_RESERVED,
    SAMPLES_NOT_YET_AVAILABLE, SAMPLES_NO_LONGER_AVAILABLE,
};
pub use api::{
    CfgDigEdgeStartTrig, CfgImplicitTiming, CfgInputBuffer, CfgSampClkTiming, CreateAiVoltageChan,
    CreateCoPulseChanFreq, CreateTask, Functions, GetDevProductType, GetErrorString,
    GetExtendedErrorInfo, GetU64, ReadAnalogF64, SetCoPulseTerm, TaskControl, TaskFn, TaskHandle,
    VAL_CFG_DEFAULT, VAL_CONT_SAMPS, VAL_DIFF, VAL_GROUP_BY_SCAN_NUMBER, VAL_HZ, VAL_NRSE, VAL_RSE,
    VAL_TASK_COMMIT, VAL_VOLTS,
};

pub use error::{DaqError, DaqmxStatus, Setting};
pub use gauges::{DaqStats, NiDaq};
pub use library::Library;
pub use settings::{CameraTrigger, DaqSettings, Terminal};
