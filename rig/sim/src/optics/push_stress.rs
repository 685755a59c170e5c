//! The stress fields a pushed contact is drawn from, per indenter outline: D1 + i D2 of a 1 N
//! press and of a 1 N tangential force along the indenter frame's +x and +y at each traction
//! level (docs/photoelastic-sim.md, "Shear and slip"), computed ahead of need.
//!
//! A level takes a traction map and two FFT convolutions on the field grid (about 40 ms at
//! full size), the press one convolution, and the first level of a process and grid the
//! Cerruti kernel spectra (about 0.2 s). Computed when a push first needed them, they stalled
//! the frame that did (frames of 0.3 s). So a background thread at background priority
//! ([`NICE`]) computes the spectra as the renderer starts and, when a contact with an outline
//! first appears ([`PushStress::prepare`]), the outline's press and all its levels, lowest
//! first (a push starts from stick); [`PushStress::compute_now`] does it at once on the
//! calling thread.
//!
//! A frame never waits for that thread: a field it needs that is not ready yet it computes
//! itself ([`OutlineStress::press`], [`OutlineStress::level`]), only that one, and whichever of
//! the two copies is stored first is kept. Both are the same deterministic computation, so a
//! frame never depends on how far the background thread got (the same seed, scene and frame
//! give the same bytes). Interpolating between the levels that happen to be ready instead would
//! draw another field than the one asked for, different from run to run; and blocking on the
//! background thread's copy could wait on a thread that, at background priority on a busy
//! machine, barely runs.

use crate::optics::fringe_field::{integrated_stress, prepare_tangential, tangential_stress};
use crate::physics::indenter::{PressureMap, Shape};
use crate::physics::stress::Layer;
use crate::physics::traction::{TractionBasis, DEFAULT_EDGE_RADIUS_MM};
use rustfft::num_complex::Complex;
use std::sync::mpsc::{channel, Receiver, Sender, TryRecvError};
use std::sync::{Arc, OnceLock, Weak};

/// Tangential traction is computed for the shares of the friction used 0, 1/8, ..., 1 (this
/// many steps, one level more) and interpolated between them.
pub(crate) const TRACTION_LEVELS: usize = 8;

/// Most outlines whose fields are kept (each holds a press field, `TRACTION_LEVELS + 1` levels
/// of two fields and the traction basis: about 25 MB at 384 x 384 cells).
pub(crate) const OUTLINE_LIMIT: usize = 4;

/// D1 + i D2 of a unit load, row-major on the field grid, in single precision (as the packed
/// fields are).
pub(crate) type StressField = Vec<Complex<f32>>;

/// D1 + i D2 of a 1 N tangential force along the indenter frame's [+x, +y], cell by cell.
pub(crate) type TractionField = Vec<[Complex<f32>; 2]>;

/// The field grid and the layer the fields are computed on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Grid {
    pub(crate) cells: usize,
    pub(crate) cell_mm: f64,
    pub(crate) layer: Layer,
}

/// The fields of one outline, each computed once by whichever thread needs it first.
#[derive(Debug)]
pub(crate) struct OutlineStress {
    shape: Shape,
    grid: Grid,
    press: OnceLock<StressField>,
    basis: OnceLock<TractionBasis>,
    levels: [OnceLock<TractionField>; TRACTION_LEVELS + 1],
}

/// The value in `cell`, computed with `make` and stored if there is none yet (when another
/// thread stored its copy meanwhile, that one is kept: they are equal).
fn ready<T>(cell: &OnceLock<T>, make: impl FnOnce() -> T) -> &T {
    match cell.get() {
        Some(v) => v,
        None => {
            let made = make();
            cell.get_or_init(|| made)
        }
    }
}

impl OutlineStress {
    fn new(shape: Shape, grid: Grid) -> OutlineStress {
        OutlineStress {
            shape,
            grid,
            press: OnceLock::new(),
            basis: OnceLock::new(),
            levels: std::array::from_fn(|_| OnceLock::new()),
        }
    }

    /// D1 + i D2 of a 1 N press.
    pub(crate) fn press(&self) -> &StressField {
        ready(&self.press, || {
            let Grid {
                cells,
                cell_mm,
                layer,
            } = self.grid;
            let map = PressureMap::new(&self.shape, cells, cell_mm, 1.0);
            integrated_stress(&map, &layer)
                .iter()
                .map(|&c| narrow(c))
                .collect()
        })
    }

    /// D1 + i D2 of a 1 N tangential force along +x and +y at traction level `level` (0 to
    /// [`TRACTION_LEVELS`], clamped): the traction carrying level / TRACTION_LEVELS of the
    /// friction limit.
    pub(crate) fn level(&self, level: usize) -> &TractionField {
        let level = level.min(TRACTION_LEVELS);
        ready(&self.levels[level], || {
            let basis = ready(&self.basis, || {
                let Grid { cells, cell_mm, .. } = self.grid;
                TractionBasis::new(&self.shape, cells, cell_mm, DEFAULT_EDGE_RADIUS_MM)
            });
            let map = basis.map(level as f64 / TRACTION_LEVELS as f64);
            let [x, y] = tangential_stress(&map, &self.grid.layer);
            x.iter()
                .zip(&y)
                .map(|(&x, &y)| [narrow(x), narrow(y)])
                .collect()
        })
    }

    /// Computes the next field not computed yet (the press, then the levels from the lowest);
    /// false when all are.
    fn fill_next(&self) -> bool {
        if self.press.get().is_none() {
            self.press();
            return true;
        }
        match (0..=TRACTION_LEVELS).find(|&k| self.levels[k].get().is_none()) {
            Some(k) => {
                self.level(k);
                true
            }
            None => false,
        }
    }

    /// Computes every field not computed yet, on this thread.
    pub(crate) fn fill(&self) {
        while self.fill_next() {}
    }

    /// Whether every field is computed.
    #[cfg(test)]
    pub(crate) fn complete(&self) -> bool {
        self.press.get().is_some() && self.levels.iter().all(|l| l.get().is_some())
    }
}

/// A stress value kept in single precision.
fn narrow(c: Complex<f64>) -> Complex<f32> {
    Complex::new(c.re as f32, c.im as f32)
}

/// The fields of the last few outlines, keyed by `K`, and the background thread that computes
/// them ahead of need.
#[derive(Debug)]
pub(crate) struct PushStress<K> {
    grid: Grid,
    /// Least recently used first.
    outlines: Vec<(K, Arc<OutlineStress>)>,
    /// Requests to the background thread (started with the first); `None` before it, or after
    /// it could not be started.
    worker: Option<Sender<Weak<OutlineStress>>>,
    /// The background thread (detached when the store is dropped).
    thread: Option<std::thread::JoinHandle<()>>,
    /// Whether to start the background thread at all (off: every field is computed on use).
    background: bool,
}

impl<K: Copy + PartialEq> PushStress<K> {
    /// An empty store for fields on `grid`, with a background thread if `background`, which
    /// starts with the layer's Cerruti kernel spectra (once per process and grid; the most
    /// costly part of a first push, about 0.2 s at full size).
    pub(crate) fn new(grid: Grid, background: bool) -> PushStress<K> {
        let mut store = PushStress {
            grid,
            outlines: Vec::new(),
            worker: None,
            thread: None,
            background,
        };
        store.start();
        store
    }

    /// The fields of outline `shape` (`key`), kept as the most recently used; the least
    /// recently used outline beyond [`OUTLINE_LIMIT`] is dropped (the background thread drops
    /// its work on it too). A new outline is handed to the background thread.
    pub(crate) fn outline(&mut self, key: K, shape: &Shape) -> Arc<OutlineStress> {
        let (outline, new) = self.entry(key, shape);
        if new {
            self.request(&outline);
        }
        outline
    }

    /// The fields of outline `shape` (`key`), all computed now on this thread (not handed to
    /// the background thread).
    pub(crate) fn compute_now(&mut self, key: K, shape: &Shape) {
        self.entry(key, shape).0.fill();
    }

    /// The entry of outline `shape` (`key`), made the most recently used, and whether it is
    /// new; the least recently used beyond [`OUTLINE_LIMIT`] is dropped.
    fn entry(&mut self, key: K, shape: &Shape) -> (Arc<OutlineStress>, bool) {
        if let Some(at) = self.outlines.iter().position(|(k, _)| *k == key) {
            let entry = self.outlines.remove(at);
            let found = Arc::clone(&entry.1);
            self.outlines.push(entry);
            return (found, false);
        }
        if self.outlines.len() >= OUTLINE_LIMIT {
            self.outlines.remove(0);
        }
        let outline = Arc::new(OutlineStress::new(*shape, self.grid));
        self.outlines.push((key, Arc::clone(&outline)));
        (outline, true)
    }

    /// Makes sure the fields of `shape` (`key`) are on their way: a contact with that outline
    /// has appeared and may be pushed soon.
    pub(crate) fn prepare(&mut self, key: K, shape: &Shape) {
        if !self.outlines.iter().any(|(k, _)| *k == key) {
            self.outline(key, shape);
        }
    }

    /// Starts the background thread (if wanted and not running).
    fn start(&mut self) {
        if !self.background || self.worker.is_some() {
            return;
        }
        let (tx, rx) = channel();
        let grid = self.grid;
        let started = std::thread::Builder::new()
            .name("push-stress".into())
            .spawn(move || {
                background_priority();
                prepare_tangential(&grid.layer, grid.cells, grid.cell_mm);
                precompute(rx);
            });
        match started {
            Ok(thread) => {
                self.worker = Some(tx);
                self.thread = Some(thread);
            }
            // Without the thread every field is computed when a frame needs it.
            Err(_) => self.background = false,
        }
    }

    /// Hands `outline` to the background thread.
    fn request(&mut self, outline: &Arc<OutlineStress>) {
        if let Some(tx) = &self.worker {
            if tx.send(Arc::downgrade(outline)).is_err() {
                self.worker = None;
            }
        }
    }
}

/// The background thread: computes the fields of the most recently requested outline still
/// kept, one field at a time, until every outline's are computed; ends when the store is
/// dropped.
fn precompute(requests: Receiver<Weak<OutlineStress>>) {
    let mut pending: Vec<Weak<OutlineStress>> = Vec::new();
    loop {
        loop {
            match requests.try_recv() {
                Ok(request) => pending.push(request),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => {
                    if pending.is_empty() {
                        return;
                    }
                    break;
                }
            }
        }
        let Some(newest) = pending.last() else {
            match requests.recv() {
                Ok(request) => pending.push(request),
                Err(_) => return,
            }
            continue;
        };
        // An outline the store dropped (or the store itself) is not worth finishing.
        let busy = newest.upgrade().is_some_and(|outline| outline.fill_next());
        if !busy {
            pending.pop();
        }
    }
}

/// Background priority (nice 10): while frames are being drawn the thread gets about a tenth of
/// a core from them (a frame that needs a field still computes it itself), and an even share
/// against other background work. At nice 19 it got so little on a busy machine that pushes
/// started before it had done anything.
const NICE: libc::c_int = 10;

/// Puts the calling thread at background priority ([`NICE`]). Best effort: elsewhere than on
/// Linux, or if refused, the thread keeps its priority.
fn background_priority() {
    #[cfg(target_os = "linux")]
    // SAFETY: gettid has no preconditions; setpriority only changes the nice value of the
    // thread it names (on Linux the nice value is per thread), here the calling one.
    unsafe {
        let tid = libc::gettid();
        libc::setpriority(libc::PRIO_PROCESS, tid as libc::id_t, NICE);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> Grid {
        Grid {
            cells: 48,
            cell_mm: 0.6,
            layer: Layer::LAYERED,
        }
    }

    #[test]
    fn the_background_thread_computes_every_field_as_a_frame_would() {
        let shape = Shape::DEFAULT_PENTAGON;
        let mut store = PushStress::new(grid(), true);
        store.prepare(1u8, &shape);
        let outline = store.outline(1u8, &shape);
        // The thread ends once its requests are done and the store no longer sends any.
        store.worker = None;
        let thread = store.thread.take().expect("the background thread started");
        thread.join().expect("the background thread did not panic");
        assert!(outline.complete(), "the thread left fields to compute");
        // A store without the thread computes each field on use: the same, bit for bit.
        let mut alone = PushStress::new(grid(), false);
        let fresh = alone.outline(1u8, &shape);
        assert!(
            !fresh.complete(),
            "nothing is computed ahead without the thread"
        );
        assert!(alone.thread.is_none());
        for k in 0..=TRACTION_LEVELS {
            assert!(outline.level(k) == fresh.level(k), "level {k}");
        }
        assert!(outline.press() == fresh.press());
        // Level 3 is the traction carrying 3/8 of the friction limit.
        let basis = TractionBasis::new(&shape, 48, 0.6, DEFAULT_EDGE_RADIUS_MM);
        let [x, y] = tangential_stress(&basis.map(3.0 / 8.0), &Layer::LAYERED);
        let expected: TractionField = x
            .iter()
            .zip(&y)
            .map(|(&x, &y)| [narrow(x), narrow(y)])
            .collect();
        assert!(*outline.level(3) == expected);
    }

    #[test]
    fn the_store_keeps_the_most_recently_used_outlines() {
        let mut store = PushStress::new(grid(), false);
        let circle = |r: f64| Shape::Circle { radius_mm: r };
        for key in 0..OUTLINE_LIMIT as u8 {
            store.prepare(key, &circle(1.0 + f64::from(key)));
        }
        // Using outline 0 again makes outline 1 the least recently used.
        let first = store.outline(0, &circle(1.0));
        store.prepare(0, &circle(1.0));
        store.prepare(9, &circle(9.0));
        let keys: Vec<u8> = store.outlines.iter().map(|(k, _)| *k).collect();
        assert_eq!(keys.len(), OUTLINE_LIMIT);
        assert!(
            !keys.contains(&1) && keys.contains(&0) && keys.contains(&9),
            "{keys:?}"
        );
        assert!(Arc::ptr_eq(&first, &store.outline(0, &circle(1.0))));
        // Computed now: every field, before the call returns.
        store.compute_now(9, &circle(9.0));
        assert!(store.outline(9, &circle(9.0)).complete());
        assert!(!first.complete());
    }
}
