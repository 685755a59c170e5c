//! The custom CNN's last convolution block trained again with its three heads, in pure Rust: what
//! a linear read-out of the pooled features cannot undo (a unit whose fringes place the contact
//! differently) needs the features themselves to move.
//!
//! The body up to the last block runs once per frame (tract); what the block reads is kept and
//! the block (conv 3x3, ReLU, max-pool 2) with the global average pool and the heads is trained
//! by mini-batch Adam, pulled towards the weights it started from. The loss is in the spec's
//! units: Fz error over 0.49 N, contact error over 1.47 mm (frames in contact), cross-entropy
//! of the shape. The presses of one fold are held out; the epoch kept is the one with the
//! least held-out error, and epoch 0 (the heads alone, fitted on the other presses) is a
//! candidate, so the block is used only where it does better on presses it never saw.

use super::held_out::{HeldOut, CONTACT_UNIT, FZ_UNIT};
use super::{run_cut_graph, AdaptError, Features};
use crate::backend::InferenceError;
use crate::dataset::{Sample, Source};
use crate::metrics::{Errors, Scored};
use crate::model::Model;
use crate::onnx_graph::conv_input_graph;
use crate::weights::state_dict::StateDict;
use crate::weights::tensor::Tensor;
use fringe_rig::seeded::SplitMix64;
use nalgebra::DMatrix;

/// The last block's convolution in the custom CNN's state dict.
pub(crate) const BLOCK: &str = "cnn.3.block.0";
/// Weight of the other force components (Fx, Fy, moments, Ft) against Fz in the loss.
const OTHER_FORCE: f64 = 0.1;

/// What the last block reads for each frame, with the frames' labels.
pub struct BlockInputs {
    /// Frames x (channels * height * width), each frame's values in C, H, W order.
    values: Vec<f32>,
    pub channels: usize,
    pub height: usize,
    pub width: usize,
    samples: Vec<Sample>,
    shapes: Vec<usize>,
}

impl BlockInputs {
    /// Runs `model`'s body up to its last block over every `every`-th frame of each source
    /// (frames of one press a frame apart are nearly the same picture). `None` for a model
    /// without the custom CNN's last block.
    pub fn read(
        model: &Model,
        sources: &[Source],
        threads: usize,
        every: usize,
        progress: impl FnMut(usize, usize),
    ) -> Result<Option<BlockInputs>, AdaptError> {
        if model.has_shear() {
            return Err(AdaptError::ShearHeads(model.path.display().to_string()));
        }
        let Some(proto) = model
            .onnx()
            .ok()
            .and_then(|p| conv_input_graph(p, &format!("{BLOCK}.weight")))
        else {
            return Ok(None);
        };
        let thinned: Vec<Source> = sources
            .iter()
            .map(|s| Source {
                samples: s.samples.iter().step_by(every.max(1)).cloned().collect(),
                ..s.clone()
            })
            .collect();
        let run = run_cut_graph(model, proto, &thinned, None, threads, progress)?;
        let per = run.per_frame;
        let channels = model
            .weights()
            .and_then(|w| w.get(&format!("{BLOCK}.weight")))
            .and_then(|t| t.shape.get(1).copied())
            .unwrap_or(0);
        let side = ((per / channels.max(1)) as f64).sqrt().round() as usize;
        if channels == 0 || side < 2 || channels * side * side != per {
            return Err(AdaptError::Features {
                path: model.path.display().to_string(),
                source: InferenceError::Outputs(format!(
                    "the last block's input came as {per} values per frame, not channels x side x side"
                )),
            });
        }
        Ok(Some(BlockInputs {
            values: run.values,
            channels,
            height: side,
            width: side,
            samples: run.samples,
            shapes: run.shapes,
        }))
    }

    pub fn len(&self) -> usize {
        self.samples.len()
    }

    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    fn frame(&self, i: usize) -> &[f32] {
        let per = self.channels * self.height * self.width;
        &self.values[i * per..(i + 1) * per]
    }
}

/// How the block is trained.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockConfig {
    pub epochs: usize,
    pub batch: usize,
    pub lr: f64,
    /// Pull towards the starting weights (L2, per parameter).
    pub pull: f64,
    pub seed: u64,
    /// Worker threads for the batches.
    pub threads: usize,
}

impl Default for BlockConfig {
    fn default() -> Self {
        BlockConfig {
            epochs: 12,
            batch: 32,
            lr: 3e-4,
            pull: 1e-3,
            seed: 42,
            threads: 2,
        }
    }
}

/// The outcome: the weights to use and the evidence for them.
#[derive(Debug, Clone)]
pub struct BlockFit {
    pub weights: StateDict,
    /// The epoch kept (0: the heads alone did best on the held-out presses).
    pub epoch: usize,
    /// The heads alone on the held-out presses.
    pub heads_only: HeldOut,
    /// The kept epoch on the held-out presses.
    pub kept: HeldOut,
    /// Held-out error per epoch (spec units), epoch 0 first.
    pub curve: Vec<f64>,
    pub held_out_presses: usize,
    pub train_frames: usize,
}

/// The parameters trained, as flat f32 vectors in the state dict's layouts.
#[derive(Clone)]
struct Params {
    conv_w: Vec<f32>,
    conv_b: Vec<f32>,
    heads: [(Vec<f32>, Vec<f32>); 3],
}

const HEADS: [&str; 3] = ["force_head", "class_head", "point_head"];

impl Params {
    fn from(sd: &StateDict) -> Option<Params> {
        let get = |k: &str| sd.get(k).map(|t| t.data.clone());
        let head = |h: &str| Some((get(&format!("{h}.weight"))?, get(&format!("{h}.bias"))?));
        Some(Params {
            conv_w: get(&format!("{BLOCK}.weight"))?,
            conv_b: get(&format!("{BLOCK}.bias"))?,
            heads: [head(HEADS[0])?, head(HEADS[1])?, head(HEADS[2])?],
        })
    }

    fn write_into(&self, sd: &mut StateDict) {
        let mut put = |k: String, v: &[f32]| {
            if let Some(t) = sd.get(&k) {
                if let Some(new) = Tensor::new(t.shape.clone(), v.to_vec()) {
                    sd.insert(&k, new);
                }
            }
        };
        put(format!("{BLOCK}.weight"), &self.conv_w);
        put(format!("{BLOCK}.bias"), &self.conv_b);
        for (h, (w, b)) in HEADS.iter().zip(&self.heads) {
            put(format!("{h}.weight"), w);
            put(format!("{h}.bias"), b);
        }
    }

    fn slices_mut(&mut self) -> Vec<&mut Vec<f32>> {
        let [(a, b), (c, d), (e, f)] = &mut self.heads;
        vec![&mut self.conv_w, &mut self.conv_b, a, b, c, d, e, f]
    }

    fn slices(&self) -> Vec<&Vec<f32>> {
        let [(a, b), (c, d), (e, f)] = &self.heads;
        vec![&self.conv_w, &self.conv_b, a, b, c, d, e, f]
    }

    fn zeros_like(&self) -> Params {
        let z = |v: &Vec<f32>| vec![0f32; v.len()];
        Params {
            conv_w: z(&self.conv_w),
            conv_b: z(&self.conv_b),
            heads: [
                (z(&self.heads[0].0), z(&self.heads[0].1)),
                (z(&self.heads[1].0), z(&self.heads[1].1)),
                (z(&self.heads[2].0), z(&self.heads[2].1)),
            ],
        }
    }

    fn add(&mut self, other: &Params) {
        for (a, b) in self.slices_mut().into_iter().zip(other.slices()) {
            a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
        }
    }
}

/// One frame through the block, pool and heads.
struct Forward {
    /// The convolution's im2col, position-major: positions x (channels * 9).
    cols: Vec<f32>,
    /// Pre-activation at each pooled cell's winning position: (channel, cell) -> (position, z).
    winners: Vec<(usize, f32)>,
    features: Vec<f32>,
    outputs: [Vec<f32>; 3],
}

/// The shape of the block.
#[derive(Clone, Copy)]
struct Dims {
    c: usize,
    h: usize,
    w: usize,
    out: usize,
}

impl Dims {
    fn k(&self) -> usize {
        self.c * 9
    }
    fn cells(&self) -> usize {
        (self.h / 2) * (self.w / 2)
    }
}

fn im2col(x: &[f32], d: Dims) -> Vec<f32> {
    let k = d.k();
    let mut cols = vec![0f32; d.h * d.w * k];
    for y in 0..d.h {
        for xx in 0..d.w {
            let row = &mut cols[(y * d.w + xx) * k..(y * d.w + xx + 1) * k];
            for ci in 0..d.c {
                for ky in 0..3 {
                    let sy = y as isize + ky as isize - 1;
                    if sy < 0 || sy >= d.h as isize {
                        continue;
                    }
                    for kx in 0..3 {
                        let sx = xx as isize + kx as isize - 1;
                        if sx < 0 || sx >= d.w as isize {
                            continue;
                        }
                        row[ci * 9 + ky * 3 + kx] = x[(ci * d.h + sy as usize) * d.w + sx as usize];
                    }
                }
            }
        }
    }
    cols
}

fn forward(p: &Params, x: &[f32], d: Dims) -> Forward {
    let k = d.k();
    let positions = d.h * d.w;
    let cols = im2col(x, d);
    let w = DMatrix::from_row_slice(d.out, k, &p.conv_w);
    let col_t = DMatrix::from_column_slice(k, positions, &cols);
    let z = w * col_t; // out x positions
    let (ph, pw) = (d.h / 2, d.w / 2);
    let mut winners = Vec::with_capacity(d.out * d.cells());
    let mut features = vec![0f32; d.out];
    for o in 0..d.out {
        let mut sum = 0f32;
        for cy in 0..ph {
            for cx in 0..pw {
                let mut best = (0usize, f32::NEG_INFINITY);
                for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                    let pos = (2 * cy + dy) * d.w + 2 * cx + dx;
                    let v = z[(o, pos)] + p.conv_b[o];
                    if v > best.1 {
                        best = (pos, v);
                    }
                }
                sum += best.1.max(0.0);
                winners.push(best);
            }
        }
        features[o] = sum / d.cells() as f32;
    }
    let outputs = std::array::from_fn(|h| {
        let (hw, hb) = &p.heads[h];
        hb.iter()
            .enumerate()
            .map(|(r, b)| {
                b + hw[r * d.out..(r + 1) * d.out]
                    .iter()
                    .zip(&features)
                    .map(|(a, f)| a * f)
                    .sum::<f32>()
            })
            .collect()
    });
    Forward {
        cols,
        winners,
        features,
        outputs,
    }
}

/// The loss's gradient with respect to the three heads' outputs for one frame.
fn output_grads(f: &Forward, s: &Sample, shape: usize) -> [Vec<f32>; 3] {
    let force: Vec<f32> = (0..f.outputs[0].len())
        .map(|j| {
            let weight = if j == 2 { 1.0 } else { OTHER_FORCE };
            let delta = f64::from(f.outputs[0][j]) - s.force.get(j).copied().unwrap_or(0.0);
            (2.0 * weight * delta / (FZ_UNIT * FZ_UNIT)) as f32
        })
        .collect();
    let logits = &f.outputs[1];
    let top = logits.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let exp: Vec<f32> = logits.iter().map(|l| (l - top).exp()).collect();
    let total: f32 = exp.iter().sum();
    let class: Vec<f32> = exp
        .iter()
        .enumerate()
        .map(|(i, e)| e / total - if i == shape { 1.0 } else { 0.0 })
        .collect();
    let point: Vec<f32> = match s.contact {
        Some(c) => (0..2)
            .map(|j| {
                (2.0 * (f64::from(f.outputs[2][j]) - c[j]) / (CONTACT_UNIT * CONTACT_UNIT)) as f32
            })
            .collect(),
        None => vec![0.0; f.outputs[2].len()],
    };
    [force, class, point]
}

/// Adds one frame's gradient to `g`.
fn backward(p: &Params, f: &Forward, s: &Sample, shape: usize, d: Dims, g: &mut Params) {
    let k = d.k();
    let grads = output_grads(f, s, shape);
    let mut d_features = vec![0f32; d.out];
    for ((grad, (hw, _)), (gw, gb)) in grads.iter().zip(&p.heads).zip(&mut g.heads) {
        for (r, dy) in grad.iter().enumerate() {
            gb[r] += dy;
            for o in 0..d.out {
                gw[r * d.out + o] += dy * f.features[o];
                d_features[o] += dy * hw[r * d.out + o];
            }
        }
    }
    let cells = d.cells();
    for (o, d_feature) in d_features.iter().enumerate() {
        let share = d_feature / cells as f32;
        for &(pos, z) in &f.winners[o * cells..(o + 1) * cells] {
            if z <= 0.0 {
                continue;
            }
            g.conv_b[o] += share;
            let col = &f.cols[pos * k..(pos + 1) * k];
            let row = &mut g.conv_w[o * k..(o + 1) * k];
            row.iter_mut().zip(col).for_each(|(a, c)| *a += share * c);
        }
    }
}

/// Frames x features of `p` over `frames` (the features the heads read).
fn features_of(p: &Params, data: &BlockInputs, frames: &[usize], d: Dims) -> Features {
    let rows: Vec<Vec<f32>> = frames
        .iter()
        .map(|&i| forward(p, data.frame(i), d).features)
        .collect();
    let matrix = DMatrix::from_fn(rows.len(), d.out, |i, j| f64::from(rows[i][j]));
    Features::from_parts(
        matrix,
        frames.iter().map(|&i| data.samples[i].clone()).collect(),
        frames.iter().map(|&i| data.shapes[i]).collect(),
    )
}

/// The held-out figures of `p` over `frames`.
fn held_out(p: &Params, data: &BlockInputs, frames: &[usize], d: Dims) -> HeldOut {
    let mut e = Errors::default();
    for &i in frames {
        let f = forward(p, data.frame(i), d);
        let s = &data.samples[i];
        let argmax = f.outputs[1]
            .iter()
            .enumerate()
            .fold(
                (0, f32::NEG_INFINITY),
                |b, (j, v)| if *v > b.1 { (j, *v) } else { b },
            )
            .0;
        e.add(&Scored {
            fz_true: s.fz(),
            fz_pred: f64::from(f.outputs[0][2]),
            shape_true: data.shapes[i],
            shape_pred: argmax,
            contact_true: s.contact,
            contact_pred: [f64::from(f.outputs[2][0]), f64::from(f.outputs[2][1])],
            shear_true: None,
            shear_pred: None,
            slip_true: None,
            slip_pred: None,
        });
    }
    HeldOut::of(&e)
}

/// The summed gradient of `batch` (frames of `data`), over `threads` threads.
fn batch_gradient(
    p: &Params,
    data: &BlockInputs,
    batch: &[usize],
    d: Dims,
    threads: usize,
) -> Params {
    let parts = threads.clamp(1, batch.len().max(1));
    let chunk = batch.len().div_ceil(parts).max(1);
    std::thread::scope(|scope| {
        let handles: Vec<_> = batch
            .chunks(chunk)
            .map(|frames| {
                scope.spawn(move || {
                    let mut g = p.zeros_like();
                    for &i in frames {
                        let f = forward(p, data.frame(i), d);
                        backward(p, &f, &data.samples[i], data.shapes[i], d, &mut g);
                    }
                    g
                })
            })
            .collect();
        let mut total = p.zeros_like();
        for h in handles {
            if let Ok(g) = h.join() {
                total.add(&g);
            }
        }
        total
    })
}

/// Adam's moments.
struct Adam {
    m: Params,
    v: Params,
    t: i32,
}

impl Adam {
    fn step(&mut self, p: &mut Params, g: &Params, start: &Params, c: &BlockConfig, n: usize) {
        self.t += 1;
        let (b1, b2, eps) = (0.9f32, 0.999f32, 1e-8f32);
        let lr = c.lr as f32;
        let (c1, c2) = (1.0 - b1.powi(self.t), 1.0 - b2.powi(self.t));
        let scale = 1.0 / n.max(1) as f32;
        let pull = c.pull as f32;
        let ms = self.m.slices_mut();
        let vs = self.v.slices_mut();
        for ((((w, gw), m), v), w0) in p
            .slices_mut()
            .into_iter()
            .zip(g.slices())
            .zip(ms)
            .zip(vs)
            .zip(start.slices())
        {
            for j in 0..w.len() {
                let grad = gw[j] * scale + pull * (w[j] - w0[j]);
                m[j] = b1 * m[j] + (1.0 - b1) * grad;
                v[j] = b2 * v[j] + (1.0 - b2) * grad * grad;
                w[j] -= lr * (m[j] / c1) / ((v[j] / c2).sqrt() + eps);
            }
        }
    }
}

/// Trains the last block and the heads of `base` on `data`, holding out the presses of
/// `held_out` (press names); the heads start from the heads alone fitted on the other presses
/// (`fit_heads`, passed in so the same fit as the heads-only adaptation is used).
pub fn train_last_block(
    base: &StateDict,
    data: &BlockInputs,
    held_out_presses: &[String],
    config: &BlockConfig,
    fit_heads: impl Fn(&Features) -> Result<StateDict, AdaptError>,
    mut progress: impl FnMut(usize, f64),
) -> Result<BlockFit, AdaptError> {
    let start = Params::from(base).ok_or(AdaptError::Singular("cnn.3 block"))?;
    let d = Dims {
        c: data.channels,
        h: data.height,
        w: data.width,
        out: start.conv_b.len(),
    };
    if start.conv_w.len() != d.out * d.k() || !d.h.is_multiple_of(2) || !d.w.is_multiple_of(2) {
        return Err(AdaptError::Singular("cnn.3 block"));
    }
    let (val, train): (Vec<usize>, Vec<usize>) =
        (0..data.len()).partition(|&i| held_out_presses.contains(&data.samples[i].press));
    if val.is_empty() || train.is_empty() {
        return Err(AdaptError::TooFew {
            presses: held_out_presses.len(),
            frames: data.len(),
        });
    }
    // Epoch 0: the base block with the heads fitted on the training presses alone.
    let mut heads_sd = base.clone();
    let fitted = fit_heads(&features_of(&start, data, &train, d))?;
    let mut p = Params::from(&fitted).ok_or(AdaptError::Singular("heads"))?;
    p.write_into(&mut heads_sd);
    let begin = p.clone();
    let heads_only = held_out(&p, data, &val, d);
    let mut best = (0usize, heads_only, p.clone());
    let mut curve = vec![heads_only.spec_units];
    let mut adam = Adam {
        m: p.zeros_like(),
        v: p.zeros_like(),
        t: 0,
    };
    let mut rng = SplitMix64::new(config.seed);
    let mut order = train.clone();
    for epoch in 1..=config.epochs {
        rng.shuffle(&mut order);
        for batch in order.chunks(config.batch.max(1)) {
            let g = batch_gradient(&p, data, batch, d, config.threads);
            adam.step(&mut p, &g, &begin, config, batch.len());
        }
        let h = held_out(&p, data, &val, d);
        curve.push(h.spec_units);
        if h.spec_units < best.1.spec_units {
            best = (epoch, h, p.clone());
        }
        progress(epoch, h.spec_units);
    }
    let mut weights = heads_sd;
    best.2.write_into(&mut weights);
    Ok(BlockFit {
        weights,
        epoch: best.0,
        heads_only,
        kept: best.1,
        curve,
        held_out_presses: held_out_presses.len(),
        train_frames: train.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tiny block (2 channels in, 3 out, 4x4) and heads, with seeded weights.
    fn tiny() -> (Params, Dims, Vec<f32>) {
        let d = Dims {
            c: 2,
            h: 4,
            w: 4,
            out: 3,
        };
        let mut rng = SplitMix64::new(7);
        let mut v = |n: usize| {
            (0..n)
                .map(|_| rng.range(-0.5..0.5) as f32)
                .collect::<Vec<_>>()
        };
        let p = Params {
            conv_w: v(d.out * d.k()),
            conv_b: v(d.out),
            heads: [(v(7 * 3), v(7)), (v(3 * 3), v(3)), (v(2 * 3), v(2))],
        };
        let x = v(d.c * d.h * d.w);
        (p, d, x)
    }

    fn loss(p: &Params, x: &[f32], s: &Sample, shape: usize, d: Dims) -> f64 {
        let f = forward(p, x, d);
        let mut l = 0.0;
        for j in 0..7 {
            let w = if j == 2 { 1.0 } else { OTHER_FORCE };
            l += w * ((f64::from(f.outputs[0][j]) - s.force[j]) / FZ_UNIT).powi(2);
        }
        let logits: Vec<f64> = f.outputs[1].iter().map(|&v| f64::from(v)).collect();
        let top = logits.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let lse = top + logits.iter().map(|l| (l - top).exp()).sum::<f64>().ln();
        l += lse - logits[shape];
        if let Some(c) = s.contact {
            for (out, want) in f.outputs[2].iter().zip(c) {
                l += ((f64::from(*out) - want) / CONTACT_UNIT).powi(2);
            }
        }
        l
    }

    #[test]
    fn the_gradient_matches_finite_differences() {
        let (p, d, x) = tiny();
        let s = Sample {
            image: "f.png".into(),
            storage: None,
            force: [0.1, -0.2, 3.0, 0.01, 0.02, 0.0, 0.3],
            shape: "pentagon".into(),
            contact: Some([1.5, -2.0]),
            shear: None,
            slip: None,
            press: "a".into(),
            stage_mm: None,
        };
        let f = forward(&p, &x, d);
        let mut g = p.zeros_like();
        backward(&p, &f, &s, 1, d, &mut g);
        let eps = 1e-3f32;
        let mut checked = 0;
        for (which, idx) in [
            (0usize, 0usize),
            (0, 5),
            (0, 40),
            (1, 1),
            (2, 3),
            (3, 2),
            (6, 4),
            (7, 1),
        ] {
            let mut plus = p.clone();
            let mut minus = p.clone();
            plus.slices_mut()[which][idx] += eps;
            minus.slices_mut()[which][idx] -= eps;
            let numeric =
                (loss(&plus, &x, &s, 1, d) - loss(&minus, &x, &s, 1, d)) / (2.0 * f64::from(eps));
            let analytic = f64::from(g.slices()[which][idx]);
            assert!(
                (numeric - analytic).abs() < 2e-2 * (1.0 + numeric.abs()),
                "parameter {which}[{idx}]: numeric {numeric}, analytic {analytic}"
            );
            checked += 1;
        }
        assert_eq!(checked, 8);
    }
}
