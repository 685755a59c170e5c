//! The policies that pick, open and judge models, one for every command and the commissioning:
//!
//! - [`choice`]: a model argument opened (a built-in name or a file), and the model a command
//!   runs when none is given (the unit's commissioned model, else the one that ships for its
//!   design).
//! - [`labelled_data`]: the labelled frames a model is evaluated or adapted on, read and
//!   checked; what they agree on of their sensor; frames it would see at another scale.
//! - [`adapted_card`]: the card of weights adapted to a unit: the unit, and how they were adapted.
//! - [`training`]: an architecture named on the command line; a training resumed from its
//!   checkpoint's data and settings (cargo feature `torch`).
//! - [`verdict`]: a spec given by name (`paper`) or file, and an evaluation's verdict against it
//!   in lines.

pub mod adapted_card;
pub mod choice;
pub mod labelled_data;
pub mod training;
pub mod verdict;
