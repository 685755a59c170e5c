//! The pressed frame against the background, per bin: the colour difference's magnitude and
//! gradient, and the gain and offset fitted away from the pattern.

pub(super) fn magnitude(diff: &[Vec<f32>; 3], n: usize) -> f64 {
    let (r, g, b) = (
        f64::from(diff[0][n]),
        f64::from(diff[1][n]),
        f64::from(diff[2][n]),
    );
    (r * r + g * g + b * b).sqrt()
}

/// Magnitude of the colour difference's gradient at bin `k` of a `bw` x `bh` grid (central
/// differences over the three channels); `None` on the grid's border. NaN when a neighbour lies
/// outside the crop.
pub(super) fn gradient(grid: &[Vec<f32>; 3], k: usize, bw: usize, bh: usize) -> Option<f64> {
    let (bi, bj) = (k % bw, k / bw);
    if bi == 0 || bj == 0 || bi + 1 >= bw || bj + 1 >= bh {
        return None;
    }
    let mut g2 = 0.0;
    for ch in grid {
        let dx = 0.5 * f64::from(ch[k + 1] - ch[k - 1]);
        let dy = 0.5 * f64::from(ch[k + bw] - ch[k - bw]);
        g2 += dx * dx + dy * dy;
    }
    Some(g2.sqrt())
}

/// Least-squares gain and offset of `p` against `b` over the used bins of `inside`.
pub(super) fn gain_offset(b: &[f32], p: &[f32], inside: &[usize], use_bin: &[bool]) -> (f32, f32) {
    let (mut n, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (&k, _) in inside.iter().zip(use_bin).filter(|(_, &u)| u) {
        let (x, y) = (f64::from(b[k]), f64::from(p[k]));
        n += 1.0;
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    let det = n * sxx - sx * sx;
    if n < 2.0 || det.abs() < 1e-9 * n * sxx.max(1.0) {
        // A flat background: offset only.
        return (1.0, if n > 0.0 { ((sy - sx) / n) as f32 } else { 0.0 });
    }
    let g = (n * sxy - sx * sy) / det;
    let o = (sy - g * sx) / n;
    (g as f32, o as f32)
}

/// Bins of `inside` usable for the gain fit: not within `radius` bins of an `above` bin.
pub(super) fn dilate_exclusion(
    inside: &[usize],
    above: &[bool],
    bw: usize,
    bh: usize,
    radius: usize,
) -> Vec<bool> {
    let mut near = vec![false; bw * bh];
    for (&k, _) in inside.iter().zip(above).filter(|(_, &a)| a) {
        let (bi, bj) = (k % bw, k / bw);
        for j in bj.saturating_sub(radius)..(bj + radius + 1).min(bh) {
            for i in bi.saturating_sub(radius)..(bi + radius + 1).min(bw) {
                near[j * bw + i] = true;
            }
        }
    }
    inside.iter().map(|&k| !near[k]).collect()
}
