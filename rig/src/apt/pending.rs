//! [`Pending`]: the motion (homing, a move, a stop) whose end an APT axis waits for.

/// What the axis is doing.
#[derive(Debug, Clone)]
pub(super) enum Pending {
    Home,
    Move(String),
    Stop(String),
}

impl Pending {
    pub(super) fn what(&self) -> String {
        match self {
            Pending::Home => "homing".to_string(),
            Pending::Move(d) => d.clone(),
            Pending::Stop(d) => format!("stopping ({d})"),
        }
    }
}

/// What a stop sent to a stage at rest is waiting for.
pub(super) const IDLE_STOP: &str = "stopping at rest";
