"""SimPy simulation of the encoder-aided node (walking-skeleton slice of the chain).

One node process ticks at the firmware rate through the execution cycle of thesis 4.2.2 (Fig. 4.10):
read sensors -> time update -> (if the schedule says so) request the encoder reference over the link,
wait for it, measurement update -> record estimate and survey.  Every array is batched over realizations,
so the SimPy event count does not depend on the number of realizations: a realization shares the event
skeleton (tick times, schedule, link delays) and owns every random draw (sensor noise, packet losses).

Timing: tick k happens at t_k = k dt.  The gyro sample used at tick k is the mean rate over [t_{k-1}, t_k).
The reference is read by the encoder one link delay d after the request and reaches the node after a
second delay; it is brought back to t_k with the rate the encoder sends: psi_ref(t_k) = psi_enc(t_k + d) - rate d.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import simpy

from firmware_model.survey import circular_moving_average, resolve_survey, trailing_moving_average
from firmware_model.yaw_filter import YawFilterConfig, make_yaw_filter
from nodesim.errors import NodesimError
from nodesim.kinematics import LabRotationProfile
from nodesim.rng import RunStreams
from nodesim.scenario import Scenario
from nodesim.schedules import UpdateSchedule
from nodesim.sensors import AccelModel, Encoder, GyroZModel
from nodesim.units import DEG, G0_M_S2


@dataclass(frozen=True)
class LabRun:
    """Per-tick outputs, arrays of shape (R, K) unless noted (SI units)."""

    t_s: np.ndarray  # (K,)
    update_mask: np.ndarray  # (R, K) reference update applied at that tick
    true_yaw_rad: np.ndarray  # (K,)
    yaw_est_rad: np.ndarray
    yaw_var_rad2: np.ndarray
    true_bias_rad_s: np.ndarray
    bias_est_rad_s: np.ndarray
    inclination_rad: np.ndarray  # moving-averaged, as the firmware reports it
    azimuth_rad: np.ndarray  # moving-averaged
    true_inclination_rad: float
    true_azimuth_rad: float
    filter_start_s: float
    rotation_end_s: float
    simpy_events: int
    firmware_overflows: dict = field(default_factory=dict)  # fixed-point saturations per site (fixed filter)


def lab_profile(scenario: Scenario) -> LabRotationProfile:
    m = scenario.motion
    return LabRotationProfile(
        inclination_rad=m.inclination_deg * DEG,
        azimuth_rad=m.azimuth_deg * DEG,
        stationary_s=m.stationary_s,
        slow_rate_rad_s=m.slow_rate_deg_s * DEG,
        slow_turns=m.slow_turns,
        pause_s=m.pause_s,
        fast_rate_rad_s=m.fast_rate_deg_s * DEG,
        fast_turns=m.fast_turns,
    )


def _check_supported(scenario: Scenario) -> float:
    dt = 1.0 / scenario.chain.firmware_rate_hz
    if scenario.chain.nodes != 1:
        raise NodesimError(
            f"chain.nodes = {scenario.chain.nodes}: this version simulates a single encoder-aided node "
            "(allowed: 1); multi-node chains come with the chain simulation core"
        )
    if 2.0 * scenario.chain.link_delay_s >= dt:
        raise NodesimError(
            f"chain.link_delay_s = {scenario.chain.link_delay_s}: the request and the reply must fit in one "
            f"firmware tick (allowed: < {dt / 2:.4g} s at {scenario.chain.firmware_rate_hz} Hz)"
        )
    return dt


def simulate_lab(scenario: Scenario) -> LabRun:
    """Run the lab scenario: R realizations of one node aided by the encoder through a simple link."""
    dt = _check_supported(scenario)
    R = scenario.simulation.realizations
    K = int(math.floor(scenario.simulation.duration_s / dt)) + 1
    t = np.arange(K) * dt
    profile = lab_profile(scenario)
    streams = RunStreams(seed=scenario.seed, n_nodes=1)
    s = scenario.sensor

    gyro = GyroZModel(
        arw_rad_per_sqrt_s=s.gyro_arw_deg_per_sqrt_s * DEG,
        turn_on_bias_rad_s=s.gyro_turn_on_bias_deg_s * DEG,
        residual_bias_rad_s=s.gyro_residual_bias_deg_s * DEG,
        bias_instability_rad_s=s.gyro_bias_instability_deg_s * DEG,
        bias_tau_s=s.gyro_bias_tau_s,
        scale_factor_error=s.gyro_scale_factor_error,
    )
    accel = AccelModel(noise_m_s2_per_sqrt_hz=s.accel_noise_ug_per_sqrt_hz * 1e-6 * G0_M_S2)
    encoder = Encoder(counts_per_rev=s.encoder_counts_per_rev)

    # sensors, batched: gyro sample k is the mean over [t_{k-1}, t_k)
    gyro_rngs = streams.sensor_batch(R, 0, "gyro")
    gm = gyro.gauss_markov(gyro_rngs, K, dt)
    true_bias = gyro.true_bias_rad_s(t[None, :], profile.motion_start_s, gm)
    true_rate = np.concatenate([[0.0], profile.mean_rate_rad_s(t[:-1], t[1:])])
    gyro_meas = (1.0 + gyro.scale_factor_error) * true_rate[None, :] + true_bias + gyro.white_noise(gyro_rngs, K, dt)
    true_yaw = profile.yaw_rad(t)
    f_sensor = accel.specific_force(profile.inclination_rad, profile.azimuth_rad, true_yaw)[None] + accel.noise(
        streams.sensor_batch(R, 0, "accel"), K, dt
    )
    link_rngs = [streams.link(r, 0) for r in range(R)]
    p_loss = scenario.chain.link_loss_probability
    delivered = np.stack([(rng.random((K, 2)) >= p_loss).all(axis=1) for rng in link_rngs])  # request and reply

    schedule = UpdateSchedule(
        scenario.schedule.mode, scenario.schedule.update_s, scenario.schedule.timeout_s, scenario.schedule.single_rate_hz
    )
    scheduled = schedule.mask(t, dt)
    f = scenario.filter
    config = YawFilterConfig(
        dt_s=dt,
        arw_rad_per_sqrt_s=gyro.arw_rad_per_sqrt_s,
        bias_instability_rad_s=gyro.bias_instability_rad_s,
        bias_tau_s=f.bias_tau_s,
        tuning_a=f.tuning_a,
        tuning_b=f.tuning_b,
    )
    delay = scenario.chain.link_delay_s
    ref_var = encoder.quantisation_sigma_rad**2

    out_yaw = np.zeros((R, K))
    out_var = np.zeros((R, K))
    out_bias = np.zeros((R, K))
    applied = np.zeros((R, K), dtype=bool)
    state: dict = {"filter": None, "bias_sum": np.zeros(R), "bias_n": 0, "events": 0}
    filter_start_s = scenario.motion.stationary_s

    env = simpy.Environment()

    def node():
        for k in range(K):
            yield env.timeout(t[k] - env.now)
            state["events"] += 1
            if t[k] < filter_start_s or k == 0:  # static window: average the gyro for the initial bias
                if k > 0:
                    state["bias_sum"] += gyro_meas[:, k]
                    state["bias_n"] += 1
                out_yaw[:, k] = encoder.read_rad(true_yaw[k])
                continue
            kf = state["filter"]
            if kf is None:
                b0 = state["bias_sum"] / max(state["bias_n"], 1)
                kf = state["filter"] = make_yaw_filter(
                    f.implementation, config, R, initial_yaw_rad=out_yaw[:, k - 1], bias_offset_rad_s=b0
                )
            kf.predict(gyro_meas[:, k])
            if scheduled[k]:
                yield env.timeout(delay)  # request leg
                state["events"] += 2
                t_read = env.now
                enc_yaw = encoder.read_rad(profile.yaw_rad(t_read))
                enc_rate = float(profile.rate_rad_s(t_read))
                yield env.timeout(delay)  # reply leg
                ok = delivered[:, k]
                kf.update(np.full(R, enc_yaw - enc_rate * delay), ref_var, mask=ok)
                applied[:, k] = ok
            out_yaw[:, k] = kf.yaw_rad
            out_var[:, k] = kf.yaw_variance_rad2
            out_bias[:, k] = kf.bias_rad_s

    env.process(node())
    env.run()

    inc_raw, azi_raw = resolve_survey(f_sensor, out_yaw)
    points = f.moving_average_points
    return LabRun(
        t_s=t,
        update_mask=applied,
        true_yaw_rad=true_yaw,
        yaw_est_rad=out_yaw,
        yaw_var_rad2=out_var,
        true_bias_rad_s=true_bias,
        bias_est_rad_s=out_bias,
        inclination_rad=trailing_moving_average(inc_raw, points),
        azimuth_rad=circular_moving_average(azi_raw, points),
        true_inclination_rad=profile.inclination_rad,
        true_azimuth_rad=profile.azimuth_rad,
        filter_start_s=filter_start_s,
        rotation_end_s=profile.rotation_end_s,
        simpy_events=state["events"],
        firmware_overflows=state["filter"].overflow_counts if state["filter"] is not None else {},
    )
