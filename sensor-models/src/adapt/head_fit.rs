//! The network's linear heads fitted again on its features, pulled towards the heads it came
//! with: ridge regression for the force and contact heads, regularised softmax regression for
//! the shape head. Closed forms and Newton steps on matrices of (features + 1) rows: a few
//! hundred for the paper's networks, so a fit takes well under a second.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

/// A linear head as the network stores it: `out = weight * features + bias`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Head {
    /// outputs x features.
    pub weight: DMatrix<f64>,
    /// One per output.
    pub bias: DVector<f64>,
}

impl Head {
    /// Outputs.
    pub(crate) fn outputs(&self) -> usize {
        self.weight.nrows()
    }

    /// The head's outputs for each row of `x` (samples x features): samples x outputs.
    pub(crate) fn apply(&self, x: &DMatrix<f64>) -> DMatrix<f64> {
        let mut out = x * self.weight.transpose();
        for mut row in out.row_iter_mut() {
            row += self.bias.transpose();
        }
        out
    }

    /// The head as one (features + 1) x outputs matrix: the weights transposed, then the bias.
    fn stacked(&self) -> DMatrix<f64> {
        let f = self.weight.ncols();
        let mut theta = DMatrix::zeros(f + 1, self.outputs());
        theta.rows_mut(0, f).copy_from(&self.weight.transpose());
        theta.row_mut(f).copy_from(&self.bias.transpose());
        theta
    }

    /// The inverse of [`Head::stacked`].
    fn from_stacked(theta: &DMatrix<f64>) -> Head {
        let f = theta.nrows() - 1;
        Head {
            weight: theta.rows(0, f).transpose(),
            bias: theta.row(f).transpose(),
        }
    }
}

/// `x` with a column of ones appended (the bias's input).
fn with_ones(x: &DMatrix<f64>) -> DMatrix<f64> {
    let (n, f) = x.shape();
    let mut a = DMatrix::from_element(n, f + 1, 1.0);
    a.columns_mut(0, f).copy_from(x);
    a
}

/// The scale of the regularisation for `x`: the mean squared feature, so that `lambda` in
/// [`ridge`] and [`softmax`] reads as a number of samples' worth of pull towards the prior.
pub(crate) fn feature_scale(x: &DMatrix<f64>) -> f64 {
    let (n, f) = x.shape();
    if n == 0 || f == 0 {
        return 1.0;
    }
    (x.norm_squared() / (n * f) as f64).max(1e-12)
}

/// Least squares pulled towards `prior`: minimises
/// `sum_i |W x_i + b - y_i|^2 + lambda * scale * |W - W_prior|^2` (the bias is not pulled), for
/// `x` samples x features and `y` samples x outputs. `None` when the system is singular (no
/// samples and no pull).
pub(crate) fn ridge(x: &DMatrix<f64>, y: &DMatrix<f64>, prior: &Head, lambda: f64) -> Option<Head> {
    let a = with_ones(x);
    let f = x.ncols();
    let pull = lambda * feature_scale(x);
    let mut lhs = a.transpose() * &a;
    for i in 0..f {
        lhs[(i, i)] += pull;
    }
    let mut rhs = a.transpose() * y;
    let theta0 = prior.stacked();
    rhs.rows_mut(0, f)
        .zip_apply(&theta0.rows(0, f), |r, t| *r += pull * t);
    let theta = Cholesky::<f64, Dyn>::new(lhs)?.solve(&rhs);
    Some(Head::from_stacked(&theta))
}

/// The probabilities of each class for each row of `logits` (samples x classes).
pub(crate) fn softmax_rows(logits: &DMatrix<f64>) -> DMatrix<f64> {
    let mut p = logits.clone();
    for mut row in p.row_iter_mut() {
        let max = row.max();
        row.apply(|v| *v = (*v - max).exp());
        let sum = row.sum();
        row /= sum;
    }
    p
}

/// Mean negative log-likelihood of the true classes `y` under `logits`.
pub(crate) fn log_loss(logits: &DMatrix<f64>, y: &[usize]) -> f64 {
    let p = softmax_rows(logits);
    let n = y.len().max(1) as f64;
    y.iter()
        .enumerate()
        .map(|(i, &c)| -(p[(i, c)].max(1e-300)).ln())
        .sum::<f64>()
        / n
}

/// Newton steps of the regularised softmax regression.
const NEWTON_STEPS: usize = 30;

/// Softmax regression pulled towards `prior`: minimises the negative log-likelihood of the
/// classes `y` (indices into the head's outputs) plus `lambda * scale / 2 * |W - W_prior|^2`, by
/// Newton's method with step halving, starting from the prior. `None` when a Newton system is
/// singular.
pub(crate) fn softmax(x: &DMatrix<f64>, y: &[usize], prior: &Head, lambda: f64) -> Option<Head> {
    let a = with_ones(x);
    let (n, d) = a.shape();
    let c = prior.outputs();
    let f = d - 1;
    let pull = lambda * feature_scale(x);
    let theta0 = prior.stacked();
    let objective = |theta: &DMatrix<f64>| -> f64 {
        let nll = log_loss(&(&a * theta), y) * n as f64;
        let diff = (theta - &theta0).rows(0, f).norm_squared();
        nll + 0.5 * pull * diff
    };
    let mut theta = theta0.clone();
    let mut current = objective(&theta);
    for _ in 0..NEWTON_STEPS {
        let p = softmax_rows(&(&a * &theta));
        let mut residual = p.clone();
        for (i, &k) in y.iter().enumerate() {
            residual[(i, k)] -= 1.0;
        }
        // Gradient and Hessian over the (d x c) parameters flattened class-major (k * d + j).
        let g = a.transpose() * residual;
        let mut grad = DVector::from_column_slice(g.as_slice());
        let mut hess = DMatrix::zeros(d * c, d * c);
        for k in 0..c {
            for l in k..c {
                let mut weighted = a.clone();
                for (i, mut row) in weighted.row_iter_mut().enumerate() {
                    let delta = if k == l { 1.0 } else { 0.0 };
                    row *= p[(i, k)] * (delta - p[(i, l)]);
                }
                let block = a.transpose() * weighted;
                hess.view_mut((k * d, l * d), (d, d)).copy_from(&block);
                if l != k {
                    hess.view_mut((l * d, k * d), (d, d))
                        .copy_from(&block.transpose());
                }
            }
        }
        for k in 0..c {
            for j in 0..f {
                grad[k * d + j] += pull * (theta[(j, k)] - theta0[(j, k)]);
                hess[(k * d + j, k * d + j)] += pull;
            }
            // The softmax is unchanged by a constant added to every logit: a tiny pull on the
            // biases keeps the Newton system solvable.
            hess[(k * d + f, k * d + f)] += 1e-9 * n.max(1) as f64;
        }
        let step = Cholesky::<f64, Dyn>::new(hess)?.solve(&grad);
        let mut scale = 1.0;
        let mut improved = false;
        for _ in 0..20 {
            let mut next = theta.clone();
            for k in 0..c {
                for j in 0..d {
                    next[(j, k)] -= scale * step[k * d + j];
                }
            }
            let value = objective(&next);
            if value <= current {
                let gain = current - value;
                theta = next;
                current = value;
                improved = gain > 1e-10 * current.abs().max(1.0);
                break;
            }
            scale *= 0.5;
        }
        if !improved {
            break;
        }
    }
    Some(Head::from_stacked(&theta))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fringe_rig::seeded::SplitMix64;

    fn zero_head(outputs: usize, features: usize) -> Head {
        Head {
            weight: DMatrix::zeros(outputs, features),
            bias: DVector::zeros(outputs),
        }
    }

    #[test]
    fn ridge_recovers_a_linear_map_and_a_strong_pull_keeps_the_prior() {
        let mut rng = SplitMix64::new(7);
        let (n, f) = (200, 6);
        let x = DMatrix::from_fn(n, f, |_, _| rng.normal());
        let truth = Head {
            weight: DMatrix::from_fn(2, f, |i, j| (i as f64 + 1.0) * (j as f64 - 2.5)),
            bias: DVector::from_vec(vec![3.0, -1.0]),
        };
        let y = truth.apply(&x);
        let fitted = ridge(&x, &y, &zero_head(2, f), 1e-9).expect("solvable");
        assert!((fitted.weight - &truth.weight).abs().max() < 1e-6);
        assert!((fitted.bias - &truth.bias).abs().max() < 1e-6);
        let prior = Head {
            weight: DMatrix::from_element(2, f, 0.5),
            bias: DVector::zeros(2),
        };
        let held = ridge(&x, &y, &prior, 1e9).expect("solvable");
        assert!((held.weight - &prior.weight).abs().max() < 1e-3);
    }

    #[test]
    fn softmax_learns_separable_classes_from_a_prior_that_confuses_them() {
        let mut rng = SplitMix64::new(3);
        let (n, f) = (150, 4);
        let y: Vec<usize> = (0..n).map(|i| i % 3).collect();
        let x = DMatrix::from_fn(n, f, |i, j| {
            rng.normal() * 0.3 + if j == y[i] { 2.0 } else { 0.0 }
        });
        // The prior says class 0 whatever the input.
        let mut prior = zero_head(3, f);
        prior.bias[0] = 3.0;
        let before = log_loss(&prior.apply(&x), &y);
        let fitted = softmax(&x, &y, &prior, 1e-3).expect("solvable");
        let logits = fitted.apply(&x);
        let after = log_loss(&logits, &y);
        let right = (0..n)
            .filter(|&i| logits.row(i).transpose().argmax().0 == y[i])
            .count();
        assert!(after < 0.2 && after < before / 10.0, "{before} -> {after}");
        assert!(right >= n - 2, "{right} of {n}");
        // A strong pull keeps the prior's answer.
        let held = softmax(&x, &y, &prior, 1e9).expect("solvable");
        assert!((held.weight - &prior.weight).abs().max() < 1e-3);
    }
}
