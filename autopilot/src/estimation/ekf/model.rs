//! The motion model and the measurement models, with their Jacobians and
//! second-order terms: pure functions of the state.

use nalgebra::{SMatrix, SVector};

use super::state::*;
use super::{STATE_LEN, StateCovariance, StateVector, wrap_pi};

/// sin(h)/h and its derivative, with series near zero where the closed forms
/// lose all their digits.
fn sinc_and_derivative(h: f64) -> (f64, f64) {
    if h.abs() < 1e-4 {
        let h2 = h * h;
        (1.0 - h2 / 6.0, -h / 3.0 + h * h2 / 30.0)
    } else {
        let (s, c) = h.sin_cos();
        (s / h, (h * c - s) / (h * h))
    }
}

/// One propagation step of `dt_s` with `v`, `κ`, `ω_p` constant: the
/// reference point moves along the exact arc. Returns the new state and the
/// Jacobian of the motion (the bias decay is applied by the caller).
pub fn propagate(x: &StateVector, dt_s: f64) -> (StateVector, StateCovariance) {
    let (yaw, v, k, wp) = (x[YAW], x[SPEED], x[CURVATURE], x[PIVOT_RATE]);
    let w = v * k + wp;
    let half = 0.5 * w * dt_s;
    let (sinc, dsinc) = sinc_and_derivative(half);
    // Chord of the arc and its direction (the mid-arc heading).
    let chord = v * dt_s * sinc;
    let (s_mid, c_mid) = (yaw + half).sin_cos();

    let mut next = *x;
    next[NORTH] += chord * c_mid;
    next[EAST] += chord * s_mid;
    next[YAW] = wrap_pi(yaw + w * dt_s);

    // d(half)/d(v, κ, ω_p) and d(chord)/d(v, κ, ω_p).
    let d_half = [0.5 * k * dt_s, 0.5 * v * dt_s, 0.5 * dt_s];
    let d_chord = [
        dt_s * sinc + v * dt_s * dsinc * d_half[0],
        v * dt_s * dsinc * d_half[1],
        v * dt_s * dsinc * d_half[2],
    ];
    let mut f = StateCovariance::identity();
    f[(NORTH, YAW)] = -chord * s_mid;
    f[(EAST, YAW)] = chord * c_mid;
    for (j, col) in [SPEED, CURVATURE, PIVOT_RATE].into_iter().enumerate() {
        f[(NORTH, col)] = d_chord[j] * c_mid - chord * s_mid * d_half[j];
        f[(EAST, col)] = d_chord[j] * s_mid + chord * c_mid * d_half[j];
        f[(YAW, col)] = 2.0 * d_half[j];
    }
    (next, f)
}

/// Rows of the motion Jacobian that differ from the identity, and the
/// columns where they do (the bias decay aside).
const MOVED_ROWS: [usize; 3] = [NORTH, EAST, YAW];
const DRIVING_COLS: [usize; 4] = [YAW, SPEED, CURVATURE, PIVOT_RATE];

/// `F·P·Fᵀ + Q` for the motion Jacobian `f` from [`propagate`] with the bias
/// decay `phi` and its exact noise `bias_q`, and continuous white noise of
/// densities `qc` integrated through the (locally linear) dynamics: with
/// M = F − I ≈ A·dt, Q ≈ dt·(Qc + (M Qc + Qc Mᵀ)/2 + M Qc Mᵀ/3), exact for
/// the double integrator (the dt³/3, dt²/2, dt terms). F − I is zero outside
/// a 3×4 block and the bias diagonal, so the products are written out: a
/// dense 8×8 triple product costs ten times more (a hundred in debug builds).
pub fn propagate_covariance(
    p: &StateCovariance,
    f: &StateCovariance,
    phi: f64,
    bias_q: f64,
    qc: &[f64; STATE_LEN],
    dt_s: f64,
) -> StateCovariance {
    let m = |i: usize, j: usize| f[(i, j)] - if i == j { 1.0 } else { 0.0 };
    // A = F·P, rows first (reading the old P only).
    let mut a = *p;
    for &i in &MOVED_ROWS {
        for k in 0..STATE_LEN {
            a[(i, k)] += DRIVING_COLS.iter().map(|&j| m(i, j) * p[(j, k)]).sum::<f64>();
        }
    }
    for b in [BIAS_NORTH, BIAS_EAST] {
        for k in 0..STATE_LEN {
            a[(b, k)] *= phi;
        }
    }
    // F·P·Fᵀ = A·Fᵀ, columns (reading A only).
    let mut out = a;
    for &i in &MOVED_ROWS {
        for k in 0..STATE_LEN {
            out[(k, i)] += DRIVING_COLS.iter().map(|&j| a[(k, j)] * m(i, j)).sum::<f64>();
        }
    }
    for b in [BIAS_NORTH, BIAS_EAST] {
        for k in 0..STATE_LEN {
            out[(k, b)] *= phi;
        }
    }
    // Q: Qc is diagonal and only v, κ, ω_p (among the driving columns) carry
    // noise into the moved rows.
    for (j, q) in qc.iter().enumerate() {
        out[(j, j)] += q * dt_s;
    }
    const NOISY: [usize; 3] = [SPEED, CURVATURE, PIVOT_RATE];
    for &i in &MOVED_ROWS {
        for &j in &NOISY {
            let half = 0.5 * m(i, j) * qc[j] * dt_s;
            out[(i, j)] += half;
            out[(j, i)] += half;
        }
        for &k in &MOVED_ROWS {
            out[(i, k)] += NOISY.iter().map(|&j| m(i, j) * qc[j] * m(k, j)).sum::<f64>() * dt_s / 3.0;
        }
    }
    out[(BIAS_NORTH, BIAS_NORTH)] += bias_q;
    out[(BIAS_EAST, BIAS_EAST)] += bias_q;
    out
}

/// The antenna position the state predicts, and its Jacobian.
pub fn antenna_position(x: &StateVector, antenna_body_m: (f64, f64)) -> (SVector<f64, 2>, SMatrix<f64, 2, STATE_LEN>) {
    let (ax, ay) = antenna_body_m;
    let (s, c) = x[YAW].sin_cos();
    let z = SVector::<f64, 2>::new(
        x[NORTH] + c * ax - s * ay + x[BIAS_NORTH],
        x[EAST] + s * ax + c * ay + x[BIAS_EAST],
    );
    let mut h = SMatrix::<f64, 2, STATE_LEN>::zeros();
    h[(0, NORTH)] = 1.0;
    h[(1, EAST)] = 1.0;
    h[(0, YAW)] = -s * ax - c * ay;
    h[(1, YAW)] = c * ax - s * ay;
    h[(0, BIAS_NORTH)] = 1.0;
    h[(1, BIAS_EAST)] = 1.0;
    (z, h)
}

/// The antenna's NED velocity the state predicts (reference-point velocity
/// plus ω × r), and its Jacobian.
pub fn antenna_velocity(x: &StateVector, antenna_body_m: (f64, f64)) -> (SVector<f64, 2>, SMatrix<f64, 2, STATE_LEN>) {
    let (ax, ay) = antenna_body_m;
    let (v, k, wp) = (x[SPEED], x[CURVATURE], x[PIVOT_RATE]);
    let w = v * k + wp;
    // Body-frame antenna velocity: (v, 0) + (0, 0, ω) × (ax, ay, 0).
    let (u, lat) = (v - w * ay, w * ax);
    let (s, c) = x[YAW].sin_cos();
    let vn = c * u - s * lat;
    let ve = s * u + c * lat;
    // dω/d(v, κ, ω_p)
    let dw = [k, v, 1.0];
    let mut h = SMatrix::<f64, 2, STATE_LEN>::zeros();
    h[(0, YAW)] = -ve;
    h[(1, YAW)] = vn;
    for (j, col) in [SPEED, CURVATURE, PIVOT_RATE].into_iter().enumerate() {
        let du = if col == SPEED { 1.0 } else { 0.0 } - dw[j] * ay;
        let dlat = dw[j] * ax;
        h[(0, col)] = c * du - s * dlat;
        h[(1, col)] = s * du + c * dlat;
    }
    (SVector::<f64, 2>::new(vn, ve), h)
}

/// Hessian of one measurement component over the states whose effect is
/// nonlinear: yaw, v, κ, ω_p (contiguous in the state, from [`YAW`]).
pub(super) type Hessian = SMatrix<f64, 4, 4>;
pub(super) const NONLINEAR: usize = YAW;

/// Second-order EKF terms: the expected value of the second-order part of
/// the measurement (½ tr(A_i P)) and its covariance (½ tr(A_i P A_j P)),
/// with P the block over [`NONLINEAR`]. Negligible once yaw and speed are
/// known (σ_yaw² ~ 1e-7), they keep the first fusions after a poor start
/// from, e.g., turning a cross-track velocity into a 100° yaw change at an
/// uncertain low speed.
pub(super) fn second_order<const M: usize>(
    p: &StateCovariance,
    hessians: &[Hessian; M],
) -> (SVector<f64, M>, SMatrix<f64, M, M>) {
    // A_i·P over the 4×4 block, then traces as sums: tr(X·Y) = Σ X_ab·Y_ba.
    let ap: [[[f64; 4]; 4]; M] = std::array::from_fn(|i| {
        std::array::from_fn(|a| {
            std::array::from_fn(|b| {
                (0..4)
                    .map(|k| hessians[i][(a, k)] * p[(NONLINEAR + k, NONLINEAR + b)])
                    .sum()
            })
        })
    });
    let trace_of_product = |x: &[[f64; 4]; 4], y: &[[f64; 4]; 4]| -> f64 {
        (0..4).map(|a| (0..4).map(|b| x[a][b] * y[b][a]).sum::<f64>()).sum()
    };
    let mean = SVector::<f64, M>::from_fn(|i, _| 0.5 * (0..4).map(|a| ap[i][a][a]).sum::<f64>());
    let cov = SMatrix::<f64, M, M>::from_fn(|i, j| 0.5 * trace_of_product(&ap[i], &ap[j]));
    (mean, cov)
}

/// Hessians of the antenna position: only yaw² (−R(yaw)·r).
pub fn antenna_position_hessians(x: &StateVector, antenna_body_m: (f64, f64)) -> [SMatrix<f64, 4, 4>; 2] {
    let (ax, ay) = antenna_body_m;
    let (s, c) = x[YAW].sin_cos();
    let rho = [c * ax - s * ay, s * ax + c * ay];
    std::array::from_fn(|i| {
        let mut a = Hessian::zeros();
        a[(0, 0)] = -rho[i];
        a
    })
}

/// Hessians of the antenna velocity h = R(yaw)·b(v, κ, ω_p) over
/// (yaw, v, κ, ω_p): yaw² gives −h, yaw×q the rotated Jacobian column, and
/// v×κ (ω = v·κ + ω_p) the lever-arm direction R(yaw)·(−a_y, a_x).
pub fn antenna_velocity_hessians(x: &StateVector, antenna_body_m: (f64, f64)) -> [SMatrix<f64, 4, 4>; 2] {
    let (ax, ay) = antenna_body_m;
    let (h, jac) = antenna_velocity(x, antenna_body_m);
    let (s, c) = x[YAW].sin_cos();
    let lever_dir = [c * -ay - s * ax, s * -ay + c * ax];
    std::array::from_fn(|i| {
        let mut a = Hessian::zeros();
        a[(0, 0)] = -h[i];
        for q in 1..4 {
            let col = NONLINEAR + q;
            // d/dyaw of R·db/dq: the column rotated by +90° (north ← −east).
            let d = if i == 0 { -jac[(1, col)] } else { jac[(0, col)] };
            a[(0, q)] = d;
            a[(q, 0)] = d;
        }
        a[(1, 2)] = lever_dir[i];
        a[(2, 1)] = lever_dir[i];
        a
    })
}
