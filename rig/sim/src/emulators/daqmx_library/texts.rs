//! The errors the simulated library returns: NI's status codes with NI's texts where NI's
//! documentation or its users quote them (`docs/nidaqmx.md`, section 4), in NI's extended
//! layout (description, details, a blank line, the task name, the status code).

use fringe_rig::nidaqmx;

/// `DAQmxErrorInvalidAttributeValue`.
pub(crate) const INVALID_ATTRIBUTE_VALUE: i32 = -200077;
/// `DAQmxErrorInvalidTask`.
pub(crate) const INVALID_TASK: i32 = -200088;
/// `DAQmxErrorReadBufferTooSmall`.
pub(crate) const BUFFER_TOO_SMALL: i32 = -200229;

/// An error the library will report: a code and the lines of its extended description.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Fault {
    pub code: i32,
    pub lines: Vec<String>,
}

impl Fault {
    pub(crate) fn new(code: i32, details: &[String]) -> Fault {
        let mut lines = vec![description(code).to_string()];
        lines.extend(details.iter().cloned());
        Fault { code, lines }
    }

    /// The extended error information for a task named `task`.
    pub(crate) fn extended(&self, task: &str) -> String {
        format!(
            "{}\n\nTask Name: {task}\n\nStatus Code: {}",
            self.lines.join("\n"),
            self.code
        )
    }
}

/// NI's description of `code`.
pub(crate) fn description(code: i32) -> &'static str {
    match code {
        nidaqmx::SAMPLES_NO_LONGER_AVAILABLE => "The application is not able to keep up with the hardware acquisition. Increasing the buffer size, reading the data more frequently, or specifying a fixed number of samples to read instead of reading all available samples might correct the problem.",
        nidaqmx::SAMPLES_NOT_YET_AVAILABLE => "Some or all of the samples requested have not yet been acquired. To wait for the samples to become available use a longer read timeout or read later in your program.",
        nidaqmx::INVALID_DEVICE_ID => "Device identifier is invalid.",
        nidaqmx::PHYSICAL_CHAN_DOES_NOT_EXIST => "Physical channel specified does not exist on this device. Refer to the documentation for channels available on this device.",
        nidaqmx::DEV_CANNOT_BE_ACCESSED => "Device cannot be accessed. Possible causes: Device is no longer present in the system. Device is not powered.",
        nidaqmx::RESOURCE_RESERVED => "The specified resource is reserved. The operation could not be completed as specified.",
        INVALID_TASK => "Task specified is invalid or does not exist.",
        BUFFER_TOO_SMALL => "Buffer is too small to fit read data.",
        INVALID_ATTRIBUTE_VALUE => "Requested value is not a supported value for this property. The property value may be invalid because it conflicts with another property.",
        _ => "The simulated NI-DAQmx library does not support this.",
    }
}
