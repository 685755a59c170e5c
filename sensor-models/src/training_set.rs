//! The network inputs and targets of one side of a split, made once before training: every
//! frame read and preprocessed (the one preprocessing, with its source's calibration profile),
//! and on the training side augmented into the pipeline's copies. Inputs are made and kept as
//! [`crate::training_input`] makes them: 8-bit grey levels, a batch turned back into normalised
//! floats.
//!
//! Targets follow the reference's training rules: Fz rounded to 0.1 N, contact x, y rounded to
//! 0.1 mm, shape as its class index ("None" = 0).

use crate::augment::{augmentation, rotate_label, Pipeline};
use crate::contact_window::ContactWindow;
use crate::dataset::Sample;
use crate::eval::{frame_ref, read_frame, EvalError};
use crate::preprocess::{Colour, Preprocessing};
use crate::training_input::{expand_inputs, stored_len, InputMaker};
use fringe_rig::seeded::{mix, SplitMix64};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// One frame to prepare: its sample, the preprocessing of its source and whether the source's
/// camera sees the stage frame mirror-reversed (its profile's registration).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Item<'a> {
    pub sample: &'a Sample,
    pub preprocessing: &'a Preprocessing,
    pub mirror: bool,
    /// For a force network: the window about the contact its inputs are cut from (the frame's
    /// labelled contact, moved by [`WINDOW_JITTER_MM`] per copy).
    pub window: Option<ContactWindow>,
}

/// Standard deviation of a force window's centre about the labelled contact, per axis, mm:
/// about the contact error of the keypoint CNN that finds the contact for the force network
/// (0.50 mm on the layered sensor, 0.71 mm on the integrated one), so that network learns to
/// read a press that is not exactly at its window's centre, and where it lies from that centre.
pub(crate) const WINDOW_JITTER_MM: f64 = 0.7;

/// The targets of one network input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Target {
    /// |Fz| rounded to 0.1 N.
    pub fz: f32,
    /// Shape class index ("None" = 0).
    pub class: i64,
    /// Contact x, y rounded to 0.1 mm, turned with the image; `None` without contact. For a
    /// force network's window: the labelled contact's offset from the window's centre (mm, the
    /// label's axes, turned with the image), what its contact head learns to read.
    pub contact: Option<[f32; 2]>,
    /// The signed shear the indenter applies to the surface, N, in the contact's axes turned
    /// with the image (unrounded); `None` where the frame's data does not know it.
    pub shear: Option<[f32; 2]>,
    /// The item it was made from.
    pub item: usize,
}

/// Why a training set could not be made.
#[derive(Debug, thiserror::Error)]
pub enum TrainingSetError {
    #[error(transparent)]
    Frame(#[from] EvalError),
    #[error("{path}: shape {shape:?} is not one of the classes {classes}")]
    Shape {
        path: String,
        shape: String,
        classes: String,
    },
    #[error("{path}: a force network's frame has no labelled contact to centre its window on")]
    NoContact { path: String },
    #[error("{path}: {source}")]
    Window {
        path: String,
        source: crate::contact_window::WindowError,
    },
    #[error("stopped")]
    Stopped,
}

/// Network inputs (8-bit) with their targets.
#[derive(Debug, Clone)]
pub(crate) struct TrainingSet {
    pub colour: Colour,
    pub input_size: u32,
    pixels: Vec<u8>,
    pub targets: Vec<Target>,
}

fn round1(v: f64) -> f32 {
    ((v * 10.0).round() / 10.0) as f32
}

impl TrainingSet {
    fn stride(&self) -> usize {
        stored_len(self.colour, self.input_size)
    }

    pub(crate) fn len(&self) -> usize {
        self.targets.len()
    }

    /// Prepares `items`: with a pipeline, its copies of each (turned, noisy); without, each
    /// once as it is (validation, test). `classes` names the shape classes ("None" first).
    /// Frames are read and preprocessed on `threads` threads; `progress` hears (frames done,
    /// frames in all); `stop` ends the work early with [`TrainingSetError::Stopped`].
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn prepare(
        items: &[Item<'_>],
        classes: &[String],
        pipeline: Option<Pipeline>,
        colour: Colour,
        input_size: u32,
        seed: u64,
        threads: usize,
        stop: &AtomicBool,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<TrainingSet, TrainingSetError> {
        let class_of = class_indices(items, classes)?;
        let job = Job {
            items,
            class_of: &class_of,
            pipeline,
            copies: pipeline.map_or(1, Pipeline::copies),
            noise: pipeline.map_or(0.0, Pipeline::noise_dn),
            colour,
            input_size,
            stride: stored_len(colour, input_size),
            seed,
            stop,
            progress,
            done: AtomicUsize::new(0),
        };
        let mut pixels = vec![0u8; items.len() * job.copies * job.stride];
        let mut targets = vec![
            Target {
                fz: 0.0,
                class: 0,
                contact: None,
                shear: None,
                item: 0,
            };
            items.len() * job.copies
        ];
        job.run(threads, &mut pixels, &mut targets)?;
        Ok(TrainingSet {
            colour,
            input_size,
            pixels,
            targets,
        })
    }

    /// Inputs `indices` as one normalised NCHW batch (three channels; grey repeated).
    pub(crate) fn batch(&self, indices: &[usize], out: &mut Vec<f32>) {
        let stride = self.stride();
        out.clear();
        for &i in indices {
            let px = &self.pixels[i * stride..(i + 1) * stride];
            expand_inputs(px, self.colour, self.input_size, out);
        }
    }
}

/// Each item's shape class index in `classes`; an error names the frame of a shape not there.
fn class_indices(items: &[Item<'_>], classes: &[String]) -> Result<Vec<i64>, TrainingSetError> {
    items
        .iter()
        .map(|it| {
            classes
                .iter()
                .position(|c| *c == it.sample.shape)
                .map(|c| c as i64)
                .ok_or_else(|| TrainingSetError::Shape {
                    path: it.sample.image.display().to_string(),
                    shape: it.sample.shape.clone(),
                    classes: classes.join(", "),
                })
        })
        .collect()
}

/// The preparation of a side, shared by the threads that do it.
struct Job<'a, 'b> {
    items: &'a [Item<'b>],
    class_of: &'a [i64],
    pipeline: Option<Pipeline>,
    /// Inputs made of each item (the pipeline's copies, else one).
    copies: usize,
    /// The pipeline's noise added to each copy, grey levels.
    noise: f64,
    colour: Colour,
    input_size: u32,
    /// Bytes per input.
    stride: usize,
    seed: u64,
    stop: &'a AtomicBool,
    progress: &'a (dyn Fn(usize, usize) + Sync),
    /// Items prepared so far, over all threads.
    done: AtomicUsize,
}

impl Job<'_, '_> {
    /// Prepares every item into `pixels` and `targets` on `threads` threads, each taking a run
    /// of consecutive items.
    fn run(
        &self,
        threads: usize,
        pixels: &mut [u8],
        targets: &mut [Target],
    ) -> Result<(), TrainingSetError> {
        let (copies, stride) = (self.copies, self.stride);
        let threads = threads.clamp(1, 64);
        let per_thread = self.items.len().div_ceil(threads).max(1);
        let results: Vec<Result<(), TrainingSetError>> = std::thread::scope(|scope| {
            let handles: Vec<_> = pixels
                .chunks_mut(per_thread * copies * stride)
                .zip(targets.chunks_mut(per_thread * copies))
                .enumerate()
                .map(|(t, (px, tg))| scope.spawn(move || self.run_from(t * per_thread, px, tg)))
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or(Err(TrainingSetError::Stopped)))
                .collect()
        });
        results.into_iter().collect()
    }

    /// One thread's share: the items from `first` on, into `px` and `tg` (as many as they
    /// hold), reporting progress after each.
    fn run_from(
        &self,
        first: usize,
        px: &mut [u8],
        tg: &mut [Target],
    ) -> Result<(), TrainingSetError> {
        let mut maker = InputMaker::new();
        for (k, (px, tg)) in px
            .chunks_mut(self.copies * self.stride)
            .zip(tg.chunks_mut(self.copies))
            .enumerate()
        {
            if self.stop.load(Ordering::Relaxed) {
                return Err(TrainingSetError::Stopped);
            }
            self.item(first + k, &mut maker, px, tg)?;
            let n = self.done.fetch_add(1, Ordering::Relaxed) + 1;
            (self.progress)(n, self.items.len());
        }
        Ok(())
    }

    /// Item `index`'s copies into `px` and `tg`: its frame read once, then each copy made by
    /// the thread's `maker` (turned by the copy's augmentation, made noisy) and stored with its
    /// target.
    fn item(
        &self,
        index: usize,
        maker: &mut InputMaker,
        px: &mut [u8],
        tg: &mut [Target],
    ) -> Result<(), TrainingSetError> {
        let it = self.items[index];
        let s = it.sample;
        let stored = read_frame(s)?;
        let frame = frame_ref(&stored);
        for copy in 0..self.copies {
            let aug = self.pipeline.map(|_| augmentation(self.seed, index, copy));
            let angle = aug.map_or(0.0, |a| a.rotation_deg);
            let config = self.preprocessing(it, index, copy)?;
            let out = &mut px[copy * self.stride..(copy + 1) * self.stride];
            maker
                .make(frame, config, aug, self.noise, out)
                .map_err(|source| EvalError::Frame {
                    path: s.image.display().to_string(),
                    source,
                })?;
            let contact = match it.window {
                // A force network's contact target: where the labelled contact lies from its
                // window's centre (the copy's jitter undone), turned with the image, unrounded.
                Some(_) => {
                    let [jx, jy] = self.jitter(index, copy);
                    let [x, y] = rotate_label([-jx, -jy], angle, it.mirror);
                    Some([x as f32, y as f32])
                }
                None => s.contact.map(|c| {
                    let [x, y] = rotate_label(c, angle, it.mirror);
                    [round1(x), round1(y)]
                }),
            };
            // A force vector turns with the image as a contact point does (the same axes).
            let shear = s.shear.map(|q| {
                let [x, y] = rotate_label(q, angle, it.mirror);
                [x as f32, y as f32]
            });
            tg[copy] = Target {
                fz: round1(s.fz()),
                class: self.class_of[index],
                contact,
                shear,
                item: index,
            };
        }
        Ok(())
    }
}

impl Job<'_, '_> {
    /// The preprocessing of copy `copy` of item `index`: its source's, at this set's input size
    /// and colour; for a force network, the window about its labelled contact (moved by the
    /// copy's jitter on an augmented side).
    fn preprocessing(
        &self,
        it: Item<'_>,
        index: usize,
        copy: usize,
    ) -> Result<Preprocessing, TrainingSetError> {
        let Some(window) = it.window else {
            return Ok(Preprocessing {
                colour: self.colour,
                input_size: self.input_size,
                ..it.preprocessing.clone()
            });
        };
        let path = || it.sample.image.display().to_string();
        let [x, y] = it
            .sample
            .contact
            .ok_or_else(|| TrainingSetError::NoContact { path: path() })?;
        let [jx, jy] = self.jitter(index, copy);
        window
            .preprocessing(
                it.preprocessing,
                [x + jx, y + jy],
                self.input_size,
                self.colour,
            )
            .map_err(|source| TrainingSetError::Window {
                path: path(),
                source,
            })
    }
}

impl Job<'_, '_> {
    /// How far copy `copy` of item `index`'s force window is moved from the labelled contact,
    /// mm: on every side, so that the validation and test figures are those of windows a first
    /// network misplaces as much as training assumes.
    fn jitter(&self, index: usize, copy: usize) -> [f64; 2] {
        jitter(self.seed, index, copy)
    }
}

/// The jitter of copy `copy` of item `index`'s window centre, mm: Gaussian, of
/// [`WINDOW_JITTER_MM`] per axis, from (seed, item, copy) alone as the augmentation is.
fn jitter(seed: u64, index: usize, copy: usize) -> [f64; 2] {
    let mut rng = SplitMix64::new(mix(mix(seed ^ 0x6a69_7474_6572, index as u64), copy as u64));
    [
        WINDOW_JITTER_MM * rng.normal(),
        WINDOW_JITTER_MM * rng.normal(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::preprocess::Centre;
    use std::path::PathBuf;

    /// A frame with a bright spot right of the centre, as a PNG.
    fn frame(dir: &std::path::Path) -> PathBuf {
        let mut img = image::RgbImage::from_pixel(200, 160, image::Rgb([20, 20, 20]));
        for y in 70..90 {
            for x in 130..150 {
                img.put_pixel(x, y, image::Rgb([250, 250, 250]));
            }
        }
        let path = dir.join("f.png");
        img.save(&path).expect("png");
        path
    }

    fn preprocessing() -> Preprocessing {
        Preprocessing {
            centre: Centre::At([100.0, 80.0]),
            crop_radius_px: 70.0,
            frame_size: None,
            sensor: "test".into(),
            input_size: 32,
            colour: Colour::Grey,
            reference: false,
        }
    }

    fn prepare(s: &Sample, pre: &Preprocessing, pipeline: Option<Pipeline>) -> TrainingSet {
        prepare_mirrored(s, pre, pipeline, false)
    }

    fn prepare_mirrored(
        s: &Sample,
        pre: &Preprocessing,
        pipeline: Option<Pipeline>,
        mirror: bool,
    ) -> TrainingSet {
        prepare_window(s, pre, pipeline, mirror, None)
    }

    fn prepare_window(
        s: &Sample,
        pre: &Preprocessing,
        pipeline: Option<Pipeline>,
        mirror: bool,
        window: Option<ContactWindow>,
    ) -> TrainingSet {
        let classes = vec!["None".to_string(), "pentagon".to_string()];
        TrainingSet::prepare(
            &[Item {
                sample: s,
                preprocessing: pre,
                mirror,
                window,
            }],
            &classes,
            pipeline,
            pipeline.map_or(Colour::Grey, Pipeline::colour),
            32,
            42,
            2,
            &AtomicBool::new(false),
            &|_, _| {},
        )
        .expect("prepare")
    }

    #[test]
    fn copies_turn_the_image_and_the_label_together() {
        let dir = tempfile::tempdir().expect("dir");
        let s = Sample {
            image: frame(dir.path()),
            storage: None,
            force: [0.0, 0.0, 3.04, 0.0, 0.0, 0.0, 3.04],
            shape: "pentagon".into(),
            contact: Some([4.0, 0.0]),
            // A push along the contact's own direction, unrounded.
            shear: Some([1.234, 0.0]),
            slip: None,
            press: "p".into(),
            stage_mm: None,
        };
        let pre = preprocessing();
        let plain = prepare(&s, &pre, None);
        assert_eq!(plain.len(), 1);
        assert_eq!(plain.targets[0].fz, 3.0);
        assert_eq!(plain.targets[0].class, 1);
        assert_eq!(plain.targets[0].shear, Some([1.234, 0.0]));
        let set = prepare(&s, &pre, Some(Pipeline::Gray10));
        assert_eq!(set.len(), 10);
        let mut batch = Vec::new();
        for k in 0..set.len() {
            set.batch(&[k], &mut batch);
            assert_eq!(batch.len(), 3 * 32 * 32);
            // The brightest input pixel lies where the turned label says (the spot sits 4 mm
            // right of the centre in a camera-view label frame).
            let (best, _) = batch[..32 * 32]
                .iter()
                .enumerate()
                .fold((0, f32::MIN), |b, (i, &v)| if v > b.1 { (i, v) } else { b });
            let (px, py) = ((best % 32) as f64 - 15.5, 15.5 - (best / 32) as f64);
            let [x, y] = set.targets[k].contact.expect("contact");
            let angle_img = py.atan2(px).to_degrees();
            let angle_label = f64::from(y).atan2(f64::from(x)).to_degrees();
            let diff = (angle_img - angle_label + 540.0).rem_euclid(360.0) - 180.0;
            assert!(
                diff.abs() < 12.0,
                "copy {k}: image at {angle_img:.0} deg, label at {angle_label:.0} deg"
            );
            // The shear turns with the image as the contact does: still along the contact,
            // still 1.234 N.
            let [qx, qy] = set.targets[k].shear.expect("shear");
            let along = (f64::from(qx) * f64::from(x) + f64::from(qy) * f64::from(y))
                / f64::from(x).hypot(f64::from(y));
            assert!((along - 1.234).abs() < 2e-3, "copy {k}: {qx}, {qy}");
        }
    }

    /// A 3 N pentagon press labelled at `contact`: a 200 x 160 frame, dark but for a bright spot
    /// over the pixels `xs` x `ys`, written as a PNG at `path`.
    fn spot_sample(
        path: &std::path::Path,
        xs: std::ops::Range<u32>,
        ys: std::ops::Range<u32>,
        contact: [f64; 2],
    ) -> Sample {
        let mut img = image::RgbImage::from_pixel(200, 160, image::Rgb([20, 20, 20]));
        for y in ys {
            for x in xs.clone() {
                img.put_pixel(x, y, image::Rgb([250, 250, 250]));
            }
        }
        img.save(path).expect("png");
        Sample {
            image: path.to_path_buf(),
            storage: None,
            force: [0.0, 0.0, 3.0, 0.0, 0.0, 0.0, 3.0],
            shape: "pentagon".into(),
            contact: Some(contact),
            shear: None,
            slip: None,
            press: "p".into(),
            stage_mm: None,
        }
    }

    /// The input pixel (x right, y up, from the input's centre) of the brightest spot.
    fn brightest(batch: &[f32], size: usize) -> [f64; 2] {
        let (best, _) = batch[..size * size]
            .iter()
            .enumerate()
            .fold((0, f32::MIN), |b, (i, &v)| if v > b.1 { (i, v) } else { b });
        let half = size as f64 / 2.0 - 0.5;
        [(best % size) as f64 - half, half - (best / size) as f64]
    }

    /// Under every registration a camera may have (mirrored or not, turned by any angle, as the
    /// integrated design's is mirrored and turned 90 degrees), each copy's label is where an
    /// unturned frame with its spot at the copy's spot would be labelled: copies teach the
    /// network the same map from image to label as the frames it will read.
    #[test]
    fn copies_keep_the_registrations_map_from_spot_to_label() {
        let dir = tempfile::tempdir().expect("dir");
        let (k, centre) = (5.0, [100.0, 80.0]);
        let contact = [4.0, 5.0];
        for (mirror, rotation_deg) in [(true, 90.0), (true, 0.0), (false, 0.0), (false, 37.0)] {
            let (s, c) = f64::to_radians(rotation_deg).sin_cos();
            let m = if mirror { -1.0 } else { 1.0 };
            // The sensor frame seen by the camera: a mirror, then a turn, counter-clockwise on
            // screen (image rows grow downwards).
            let to_input = |[x, y]: [f64; 2]| [k * (c * m * x - s * y), k * (s * m * x + c * y)];
            let [du, dv_up] = to_input(contact);
            let (u, v) = (centre[0] + du, centre[1] - dv_up);
            let sample = spot_sample(
                &dir.path().join(format!("{mirror}-{rotation_deg}.png")),
                (u as u32 - 4)..(u as u32 + 4),
                (v as u32 - 4)..(v as u32 + 4),
                contact,
            );
            let set = prepare_mirrored(&sample, &preprocessing(), Some(Pipeline::Gray10), mirror);
            // Input pixels per frame pixel: 32 px for the 140 px crop.
            let scale = 32.0 / 140.0;
            let mut batch = Vec::new();
            for copy in 0..set.len() {
                set.batch(&[copy], &mut batch);
                let spot = brightest(&batch, 32);
                let label = set.targets[copy].contact.expect("contact");
                let [eu, ev] = to_input([f64::from(label[0]), f64::from(label[1])]);
                let want = [eu * scale, ev * scale];
                let miss = ((spot[0] - want[0]).powi(2) + (spot[1] - want[1]).powi(2)).sqrt();
                assert!(
                    miss < 1.5,
                    "mirror {mirror}, turn {rotation_deg} deg, copy {copy}: spot at {spot:?} px, \
                     the label {label:?} mm says {want:?} px"
                );
            }
        }
    }

    /// A force network's copies: each window is moved from the labelled contact by its jitter,
    /// and its contact target is where the press then lies from the window's centre, under every
    /// registration and turn of the image (the offset the two-stage model adds to the first
    /// network's contact). Without the target following the jitter and the turn, the network
    /// would learn to move the contact the wrong way.
    #[test]
    fn a_force_windows_contact_target_is_where_its_press_lies_from_the_centre() {
        let dir = tempfile::tempdir().expect("dir");
        let (k, centre) = (5.0, [100.0, 80.0]);
        let contact = [4.0, 5.0];
        for (mirror, rotation_deg) in [(true, 90.0), (true, 0.0), (false, 0.0), (false, 37.0)] {
            let window = ContactWindow::new(8.0, k, rotation_deg, mirror);
            let [du, dv] = window.offset_px(contact);
            let (u, v) = (centre[0] + du, centre[1] + dv);
            let sample = spot_sample(
                &dir.path().join(format!("{mirror}-{rotation_deg}.png")),
                (u.round() as u32 - 3)..(u.round() as u32 + 3),
                (v.round() as u32 - 3)..(v.round() as u32 + 3),
                contact,
            );
            let set = prepare_window(
                &sample,
                &preprocessing(),
                Some(Pipeline::Gray10),
                mirror,
                Some(window),
            );
            // The 8 mm window is 40 frame px across, 32 input px: 4 input px per mm.
            let per_mm = 32.0 / 8.0;
            let mut batch = Vec::new();
            let mut moved = 0.0f64;
            for copy in 0..set.len() {
                set.batch(&[copy], &mut batch);
                // The spot's centroid, input px from the centre (x right, y down).
                let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
                for (i, &val) in batch[..32 * 32].iter().enumerate() {
                    if val > 0.0 {
                        sx += (i % 32) as f64 - 15.5;
                        sy += (i / 32) as f64 - 15.5;
                        n += 1.0;
                    }
                }
                assert!(n > 0.0, "copy {copy}: no spot in the window");
                let spot = [sx / n, sy / n];
                let target = set.targets[copy].contact.expect("an offset");
                let [ox, oy] = window.offset_px([f64::from(target[0]), f64::from(target[1])]);
                let want = [ox / k * per_mm, oy / k * per_mm];
                let miss = ((spot[0] - want[0]).powi(2) + (spot[1] - want[1]).powi(2)).sqrt();
                assert!(
                    miss < 1.0,
                    "mirror {mirror}, turn {rotation_deg} deg, copy {copy}: spot at {spot:?} \
                     input px, the offset {target:?} mm says {want:?}"
                );
                moved = moved.max(f64::from(target[0]).hypot(f64::from(target[1])));
            }
            assert!(
                moved > 0.3,
                "mirror {mirror}, turn {rotation_deg} deg: no copy's window was moved ({moved} mm)"
            );
        }
    }
}
