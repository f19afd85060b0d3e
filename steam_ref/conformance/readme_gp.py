"""The exported README's sections "Motion priors" and "Interpolation and prediction": Φ(s), Q(s), Q⁻¹, W and vᵢ of
every model the gp suite's cases compute (WNOA, WNOJ, Singer, a general LTI SDE) and Λ(τ), Ψ(τ), the mean, the
covariance at τ and the prediction, written out so that a port needs nothing outside the kit (the derivations behind
them are docs/derivations.md §1, §3, §6 and §7 of steam_ref's source; [YIB Eq. 14, 16-18, 23, 30-31])."""

from __future__ import annotations

__all__ = ["GP_MODELS", "GP_INTERPOLATION"]

GP_MODELS = """What the gp suite's `wnoa`, `wnoj`, `singer` and `lti` cases compute, and the Phi(s), Q(s) of an elapsed time s
that the interpolation and the prediction (next section) and the `gp_prior` factor use. Every model is an LTI SDE
x_dot = A x + v + F w, w ~ GP(0, Qc delta(t - t')) [YIB Eq. 14], over an elapsed time s > 0
(s = t_i - t_(i-1) for a prior) [YIB Eq. 16-17, 23]:

    Phi(s) = expm(A s),   Q(s) = integral_0^s Phi(u) F Qc F^T Phi(u)^T du,   v_i = integral_0^s Phi(u) du v

(Eq. 17 and 23 with u = t_i - s': Phi(s) is the paper's Phi(t_i, t_(i-1)); only elapsed times enter, never a
clock's absolute time). M (x) N is the Kronecker product, block (k, l) of it M_kl N: a state is stacked by
derivative in blocks of 3, [p; p_dot] or [p; p_dot; p_ddot] with p = [x, y, theta] (conventions, state), never
axis by axis ([x, x_dot, y, ...]); Qc is 3x3 (any symmetric positive definite, not only diagonal), I the 3x3
identity. The closed forms below are derived in steam_ref's docs/derivations.md (§1 WNOA, §6 WNOJ and Singer).

**WNOA** (`wnoa`; the interpolation, interpolation_covariance and extrapolation cases; `gp_prior` and
`interpolated` factors; conventions, gp_prior): x = [p; p_dot], p_ddot = w [YIB Eq. 30-31]:

    Phi(s)    = [[1, s], [0, 1]] (x) I
    Q(s)      = [[s^3/3, s^2/2], [s^2/2, s]] (x) Qc
    Q(s)^-1   = [[12/s^3, -6/s^2], [-6/s^2, 4/s]] (x) Qc^-1

W (conventions, whitening) is the upper-triangular matrix with positive diagonal and W^T W = Q(s)^-1: the transpose
of the lower Cholesky factor L of Q(s)^-1 = L L^T (equivalently U^-1 for Q(s) = U U^T with U upper triangular).

**WNOJ** (`wnoj`, and the se3 suite's WNOJ prior): x = [p; p_dot; p_ddot], p_dddot = w,
A = [[0, 1, 0], [0, 0, 1], [0, 0, 0]] (x) I, F = [0; 0; 1] (x) I:

    Phi(s)    = [[1, s, s^2/2], [0, 1, s], [0, 0, 1]] (x) I
    Q(s)      = [[s^5/20, s^4/8, s^3/6], [s^4/8, s^3/3, s^2/2], [s^3/6, s^2/2, s]] (x) Qc
    Q(s)^-1   = [[720/s^5, -360/s^4, 60/s^3], [-360/s^4, 192/s^3, -36/s^2], [60/s^3, -36/s^2, 9/s]] (x) Qc^-1

**Singer** (`singer`, `singer_interpolation`): x = [p; p_dot; p_ddot], p_dddot = -alpha p_ddot + w: the acceleration
is an Ornstein-Uhlenbeck process; `alpha` > 0 is its rate in 1/s, one over its time constant (not the time constant),
and Qc = 2 alpha sigma_m^2 for a maneuver variance sigma_m^2 per axis. A = [[0, 1, 0], [0, 0, 1], [0, 0, -alpha]] (x)
I, F = [0; 0; 1] (x) I. With z = alpha s (a number, not the state x) and E = exp(-z):

    Phi(s)    = [[1, s, (z - 1 + E)/alpha^2], [0, 1, (1 - E)/alpha], [0, 0, E]] (x) I
    Q(s)      = [[s^5 S_pp, s^4 S_pv, s^3 S_pa], [s^4 S_pv, s^3 S_vv, s^2 S_va], [s^3 S_pa, s^2 S_va, s S_aa]] (x) Qc

    S_pp = (z^3/3 - z^2 + z - 2 z E + (1 - E^2)/2) / z^5     S_pv = (z - 1 + E)^2 / (2 z^4)
    S_pa = ((1 - E^2)/2 - z E) / z^3                       S_vv = (z - 3/2 + 2 E - E^2/2) / z^3
    S_va = (1 - E)^2 / (2 z^2)                             S_aa = (1 - E^2) / (2 z)

(Q_aa = Qc (1 - exp(-2 alpha s))/(2 alpha), the OU variance.) As z -> 0 these tend to WNOJ's, but as written they
cancel there (S_pp's numerator is z^5/20 + ... made of terms of size 1: a relative eps/z^5 lost): for z <= 1 sum the
series S_kl(z) = sum_n (-z)^n / (k + l + n + 1) sum_(i=0..n) 1 / ((i + k)! (n - i + l)!), with k, l = 2, 1, 0 for
p, v, a (24 terms reach 1e-18), and Phi's (z - 1 + E)/z^2 = sum_n (-z)^n / (n + 2)!. The kit's Singer cases have
alpha s from 0.24 to 4.5, where the closed forms as written lose at most 1.1e-12 of an entry (S_pp at 0.24), inside
every tolerance.

**General LTI** (`lti`: A n x n, F n x m, Qc m x m, a constant input v of n): Phi(s) = expm(A s), and Q(s) and v_i by
Van Loan's block exponentials (derivations §1; or by quadrature of the integrals above, as the kit's oracle does):

    expm([[-A, F Qc F^T], [0, A^T]] s) = [[E11, E12], [0, E22]],   Q(s) = E22^T E12
    expm([[A, v], [0, 0]] s) = [[Phi(s), v_i], [0, 1]]

The `gp_prior` error with an input is e = x_i - Phi(s) x_(i-1) - v_i (conventions, residual); no case has v but `lti`.
"""

GP_INTERPOLATION = """What the gp suite's interpolation, its covariance and the prediction compute (and the `interpolated`
factor's x(tau)), with Phi(s) and Q(s) the matrices of an elapsed time s of the case's model (section 'Motion priors':
WNOA for `interpolation`, `interpolation_covariance`, `extrapolation` and the `interpolated` factor, Singer's with
its alpha for `singer_interpolation`, WNOJ for the se3 suite's WNOJ local GP):

    Psi(tau)    = Q(tau - t1) Phi(t2 - tau)^T Q(t2 - t1)^-1
    Lambda(tau) = Phi(tau - t1) - Psi(tau) Phi(t2 - t1)                    [YIB Eq. 16]
    x_tau       = Lambda(tau) x1 + Psi(tau) x2                             [YIB Eq. 18] (prior mean cancels)

Q_tau of Eq. 16 is Q(tau - t1), measured from the earlier state, and Phi(t_i, tau) is Phi(t2 - tau) (a port that
measures tau from t2 passes interp_tau1.3 alone: its tau is the midpoint). With joint_cov P the covariance of [x1; x2],

    cov_tau = [Lambda Psi] P [Lambda Psi]^T + Q(tau - t1) - Psi(tau) Phi(t2 - tau) Q(tau - t1)

(the second part is the GP's own conditional covariance of x(tau) given x1, x2). The prediction after the last
state: x_t = Phi(t - t1) x1, cov_t = Phi(t - t1) cov1 Phi(t - t1)^T + Q(t - t1).
"""
