//! Which F/T interface a bring-up command streams from: it chooses the CSV's columns and the
//! words of the errors.

/// The F/T interface of a bring-up command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interface {
    /// `fringe ft`: an ATI Net F/T, whose records carry the RDT and F/T sequence numbers.
    NetFt,
    /// `fringe daq`: an NI-DAQmx device, whose samples carry their index and, when `strobe`,
    /// the camera's exposure strobe.
    Daq { strobe: bool },
}
