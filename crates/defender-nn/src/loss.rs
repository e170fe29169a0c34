//! Losses with their gradients.

use faer::{MatMut, MatRef};

#[track_caller]
fn check(pred: MatRef<'_, f32>, target: MatRef<'_, f32>) {
    assert!(
        pred.nrows() == target.nrows() && pred.ncols() == target.ncols(),
        "mse_loss: prediction is {}x{}, target is {}x{}",
        pred.nrows(),
        pred.ncols(),
        target.nrows(),
        target.ncols()
    );
}

/// Mean squared error over all elements, `mean((pred - target)^2)` (PyTorch's `F.mse_loss`),
/// summed in f64. An empty input gives 0.
///
/// # Panics
///
/// If the shapes differ.
#[track_caller]
pub fn mse_loss(pred: MatRef<'_, f32>, target: MatRef<'_, f32>) -> f32 {
    check(pred, target);
    let n = pred.nrows() * pred.ncols();
    if n == 0 {
        return 0.0;
    }
    let mut sum = 0.0f64;
    for j in 0..pred.ncols() {
        for i in 0..pred.nrows() {
            let d = (pred[(i, j)] - target[(i, j)]) as f64;
            sum += d * d;
        }
    }
    (sum / n as f64) as f32
}

/// [`mse_loss`] and its gradient w.r.t. `pred`, `2 (pred - target) / n`, written into `grad`
/// (same shape; preallocate it once). Returns the loss.
///
/// # Panics
///
/// If the shapes differ.
#[track_caller]
pub fn mse_loss_grad(pred: MatRef<'_, f32>, target: MatRef<'_, f32>, mut grad: MatMut<'_, f32>) -> f32 {
    check(pred, target);
    assert!(
        grad.nrows() == pred.nrows() && grad.ncols() == pred.ncols(),
        "mse_loss_grad: grad is {}x{}, prediction is {}x{}",
        grad.nrows(),
        grad.ncols(),
        pred.nrows(),
        pred.ncols()
    );
    let n = pred.nrows() * pred.ncols();
    if n == 0 {
        return 0.0;
    }
    let scale = 2.0 / n as f32;
    let mut sum = 0.0f64;
    for j in 0..pred.ncols() {
        for i in 0..pred.nrows() {
            let d = pred[(i, j)] - target[(i, j)];
            sum += (d as f64) * (d as f64);
            grad[(i, j)] = scale * d;
        }
    }
    (sum / n as f64) as f32
}
