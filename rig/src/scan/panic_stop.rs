//! Axes stopped when the thread that moves them panics. A move is a command the controller
//! carries out on its own: the scan thread that sent it, gone in a panic (a defect), would never
//! stop it, and dropping a driver closes its link without a word to the controller. The axes of
//! the scan (and of the bench outside scans) are stopped where they are as the thread unwinds.

use crate::axis::{Axis, StopMode};

/// Stops each of `axes` at once when the calling thread is unwinding from a panic (errors are
/// ignored: the thread is going, and each axis is tried).
pub fn stop_if_panicking(axes: [&mut dyn Axis; 3]) {
    if std::thread::panicking() {
        for axis in axes {
            let _ = axis.stop(StopMode::Immediate);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::{AxisError, AxisStatus};
    use crate::units::Millimetres;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    use std::time::Duration;

    /// An axis that counts the stops it was sent.
    struct Counting(Arc<AtomicUsize>);

    impl Axis for Counting {
        fn name(&self) -> &str {
            "z"
        }
        fn endpoint(&self) -> String {
            "test".into()
        }
        fn begin_home(&mut self) -> Result<(), AxisError> {
            Ok(())
        }
        fn begin_move_to(&mut self, _: Millimetres) -> Result<(), AxisError> {
            Ok(())
        }
        fn begin_move_by(&mut self, _: Millimetres) -> Result<(), AxisError> {
            Ok(())
        }
        fn begin_move_to_at(
            &mut self,
            _: Millimetres,
            _: crate::axis::Kinematics,
        ) -> Result<(), AxisError> {
            Ok(())
        }
        fn wait_idle(&mut self, _: Duration) -> Result<AxisStatus, AxisError> {
            self.status()
        }
        fn stop(&mut self, _: StopMode) -> Result<(), AxisError> {
            self.0.fetch_add(1, Ordering::SeqCst);
            Ok(())
        }
        fn status(&mut self) -> Result<AxisStatus, AxisError> {
            Ok(AxisStatus {
                position: Millimetres(0.0),
                moving: true,
                homed: true,
                flags: Vec::new(),
                faults: Vec::new(),
            })
        }
    }

    /// Holds three axes as the scan does, stopping them when dropped in a panic.
    struct Held([Counting; 3]);

    impl Drop for Held {
        fn drop(&mut self) {
            let [x, y, z] = &mut self.0;
            stop_if_panicking([x, y, z]);
        }
    }

    fn held(stops: &Arc<AtomicUsize>) -> Held {
        Held([0, 1, 2].map(|_| Counting(stops.clone())))
    }

    #[test]
    fn a_panic_while_the_axes_are_held_stops_every_one_of_them() {
        let stops = Arc::new(AtomicUsize::new(0));
        let axes = held(&stops);
        let died = std::thread::spawn(move || {
            let _held = axes;
            panic!("a defect mid-move");
        })
        .join();
        assert!(died.is_err());
        assert_eq!(stops.load(Ordering::SeqCst), 3, "each axis stopped");
        // An ordinary end stops nothing (the scan retracts and stops as it ends).
        let quiet = Arc::new(AtomicUsize::new(0));
        drop(held(&quiet));
        assert_eq!(quiet.load(Ordering::SeqCst), 0);
    }
}
