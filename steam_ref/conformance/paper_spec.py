"""The paper suite's set-up, every field and the run's procedure, in words another implementation can follow.

The paper cases carry these texts in their inputs (``setup_fields``, ``procedure``) and the exported
README repeats them, so that BTGP/1 can be run from the kit without steam_ref's code.  [YIB Sec. IV]
"""

from __future__ import annotations

__all__ = ["SETUP_FIELDS", "PROCEDURE"]

SETUP_FIELDS = {
    "name": "'synthetic' or 'plaza': which of the paper's experiments",
    "qc": "(3, 3) power spectral density Qc of the WNOA prior on p = [x, y, theta] [YIB Eq. 31]",
    "velocity_sigmas": "(3,) sigmas of a projected-velocity reading [forward, lateral, yaw rate] at an estimated state",
    "interpolated_velocity_sigmas": "(3,) sigmas of the same reading when it falls between states (interpolated, "
    "[YIB Eq. 29])",
    "range_sigma": "[m] sigma of a range reading",
    "tukey_c": "Tukey threshold c on the whitened range error (null: plain least squares)",
    "landmark_prior_sigma": "[m] isotropic sigma of the prior on a landmark at its surveyed position [YIB Eq. 4]",
    "first_pose_sigmas": "(3,) sigmas of the prior on pose 0 at its ground truth",
    "first_velocity_sigmas": "(3,) sigmas of the prior on velocity 0",
    "first_velocity": "(3,) the mean of that prior",
    "range_correction_steps": "fit r' = a r + b to the ranges of the first N poses against ground truth and "
    "correct all ranges with it; 0: none",
    "start_after_ranges": "nothing is solved until this many ranges have arrived; then one batch Levenberg-Marquardt "
    "solve (GTSAM's defaults, relative and absolute tolerance 1e-5) of everything so far seeds iSAM2",
    "landmarks_up_front": "true: every landmark and its prior enter at pose 0; false: at its first sighting",
    "range_attachment": "'file-order': a range belongs to the pose at which the data file's scan reaches it "
    "(the authors' scripts); 'time': to the pose by its time stamp",
    "pose2_heading_rate_guess": "true: the initial heading rate of a new state is the difference of two headings "
    "each wrapped to (-pi, pi] over dt (so off by 2 pi / dt where the heading crosses pi, as the scripts); false: "
    "the plain difference",
    "relinearize_blocks": "[3, 3]: iSAM2 checks and moves pose and velocity of a state on their own, as GTSAM does "
    "for two variables P and V; null: the whole state",
    "final_updates": "extra iSAM2 updates with no new factors after the last pose",
    "prior": "the motion prior: 'wnoa' (the paper's)",
    "singer_time_constant": "unused by WNOA",
    "first_acceleration_sigmas": "unused by WNOA",
    "every": "the schedule: update after this many landmark readings (1: BTGP/1)",
}

PROCEDURE = [
    (
        "Every pose of the data file is a state x_i = [x, y, theta, x_dot, y_dot, theta_dot] at the pose's "
        "time (method 'btgp', every 1); each new state i > 0 brings a gp_prior factor on (x_{i-1}, x_i) with "
        "the set-up's qc and dt = t_i - t_{i-1}."
    ),
    (
        "State 0: a prior on its pose at ground truth (first_pose_sigmas) and on its velocity at "
        "first_velocity (first_velocity_sigmas), both on the six numbers as one prior with those sigmas."
    ),
    (
        "A velocity reading [forward, lateral, yaw rate] at a pose: a 'velocity' factor with velocity_sigmas;"
        " a range to landmark j: a 'range' factor with range_sigma and Tukey(tukey_c); a landmark enters (see"
        " landmarks_up_front) at its surveyed position with a prior of landmark_prior_sigma."
    ),
    (
        "Initial value of a new state: the previous pose composed (SE(2)) with [forward, lateral, yaw rate] *"
        " dt of the previous velocity reading; its velocity the backward difference (p_i - p_{i-1}) / dt (see"
        " pose2_heading_rate_guess). After each update, prediction continues from the latest estimate."
    ),
    (
        "Schedule: after start_after_ranges ranges (and the seeding batch solve), one iSAM2 update at a state"
        " once 'every' landmark readings have arrived since the last update, and at the last pose; then "
        "final_updates empty updates."
    ),
    (
        "iSAM2: GTSAM's defaults (relinearize threshold 0.1, relinearize_skip 10, wildfire threshold 0.001) "
        "with relinearize_blocks; the result is the estimate after the last update."
    ),
    (
        "Outputs: the final [x, y, theta] (poses) and [x_dot, y_dot, theta_dot] (velocities) at the states "
        "listed in state_poses (pose indices), every landmark by id, and rmse_m, the root mean square "
        "position error against the data file's ground truth over all states."
    ),
]
