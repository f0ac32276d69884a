"""Feed a recorded log to the firmware model at its recorded times, as the node MCU would.

Per node (each node of a multi-node log is replayed with the references it recorded):
  1. ticks: the rows marked ``tick`` (the recorded firmware's own tick times) or, without that column, a
     grid t_0 + k / f_firmware from the node's first sample to its last;
  2. resampling: each tick averages the samples in (t_{k-1}, t_k] (gyro z and the accelerometer triad,
     :func:`nodesim.sensors.imu.average_per_tick`); a tick inside a repaired gap holds the previous average;
  3. static window (the ticks the log marks ``static``, else those with t < t_log + ``bias_window_s``, t_log
     the log's first time): the gyro is summed for the initial bias and the reported yaw is the encoder's;
  4. the first tick after it starts the filter from the encoder yaw and the mean bias (no time update in
     that tick); every later tick runs the time update with the tick's gyro mean, then a measurement update
     where the schedule gives a reference, except the ticks marked ``hold`` (state kept, nothing done);
  5. the survey: inclination and azimuth from the tick-averaged specific force and the yaw at the middle of the
     tick's window (thesis eqs 1.1-1.3), the alignment offset of the configuration's ``firmware.alignment``
     window (at t_log + its times), then the firmware's N-point moving average;
  6. frames (fixed firmware): at every tick where the log records an estimate frame sent (column ``frame``), the
     replay encodes its own from its firmware words (:func:`nodesim.chain.packets.estimate_frame`, the chain's
     encoder: seq = the tick since power-up, t_read_us = the tick time in us) for the comparison with the log.
This is the convention of the chain simulation's node process (``nodesim.chain.node_process``), so a log it
recorded replays bit for bit.  Schedules:
  - ``recorded``: the updates the log records (``ref_update``, with ``ref_yaw`` and ``ref_var``);
  - imposed (``continuous``, ``windowed:U:T``, ``single:F``, ``none``, or ``config`` for the firmware
    configuration's ``[schedule]``, which may also be ``arbitrary`` windows): :class:`nodesim.scenario.schedules.UpdateSchedule` evaluated at t - t_log.
    A scheduled tick uses the reference the log recorded at that tick when it has one; otherwise, on the
    top node, the latest encoder reading at or before the tick with the quantisation variance q^2 / 12.
    Nodes below the top only get recorded references (they are not re-propagated down the chain).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from firmware_model import fixed_kernel as fk
from firmware_model import fixedpoint as fxp
from firmware_model import node_firmware as nf
from firmware_model.config import FirmwareConfig
from firmware_model.fixed_filter import FixedFormats
from firmware_model.filter_factory import make_yaw_filter
from firmware_model.yaw_filter import YawFilterConfig
from nodesim.sensors.allan import AllanNoise, overlapping_adev, read_noise
from nodesim.chain.compiled.surveys import averaged_surveys
from firmware_model import frames as fr
from nodesim.chain.estimator import (FirmwareLanes, alignment_ticks, alignment_window_s, filter_config,
                                    firmware_config, fixed_formats, timer_us)
from nodesim.chain.packets import estimate_frame
from nodesim.chain.network import schedule_of
from nodesim.errors import NodesimError
from nodesim.replay.reader import NodeLog, ReplayLog
from nodesim.scenario.schema import Scenario
from nodesim.scenario.schedules import UpdateSchedule
from nodesim.sensors.encoder import RotaryEncoder
from nodesim.sensors.chain_imu import GYRO_LSB_PER_DEG_S, ChainImu
from nodesim.sensors.imu import average_per_tick, sum_per_tick
from nodesim.units import G0_M_S2
from firmware_model import node_survey

SCHEDULE_HELP = "recorded | config | continuous | none | windowed:UPDATE_S:TIMEOUT_S | single:RATE_HZ"


@dataclass(frozen=True)
class FirmwareSetup:
    """What the replay needs from a firmware configuration (a scenario TOML: ``[filter]``, ``[schedule]``,
    ``chain.firmware_rate_hz``, ``motion.stationary_s`` as the static bias window, ``sensor.gyro_*`` noise,
    ``sensor.encoder_counts_per_rev``)."""

    implementation: str
    filter_config: YawFilterConfig
    rate_hz: float
    bias_window_s: float
    moving_average_points: int
    encoder_variance_rad2: float
    config_schedule: UpdateSchedule
    noise_source: str = "config"
    formats: FixedFormats | None = None  # fixed filter: its Q formats (filter.fixed_word_bits)
    firmware: FirmwareConfig | None = None  # fixed implementation: the firmware build the chain runs
    accel_lsb_per_g: float = 16384.0  # the configured accelerometer range's sensitivity (sensor.accel_full_scale_g)
    alignment_window_s: tuple[float, float] | None = None  # firmware.alignment's window after the log's start

    @classmethod
    def from_scenario(cls, scenario: Scenario, noise: AllanNoise | None = None) -> "FirmwareSetup":
        s, f = scenario.sensor, scenario.filter
        config = filter_config(scenario)  # the chain's own tuning, so a recorded run replays bit for bit
        if noise is not None:
            config = replace(config, arw_rad_per_sqrt_s=noise.arw, bias_instability_rad_s=noise.bias_instability)
        return cls(
            implementation=f.implementation,
            filter_config=config,
            rate_hz=scenario.chain.firmware_rate_hz,
            bias_window_s=scenario.motion.stationary_s,
            moving_average_points=f.moving_average_points,
            encoder_variance_rad2=RotaryEncoder(counts_per_rev=s.encoder_counts_per_rev).quantisation_sigma_rad ** 2,
            config_schedule=schedule_of(scenario),
            noise_source="allan" if noise else "config",
            formats=fixed_formats(scenario),
            firmware=firmware_config(scenario) if f.implementation == "fixed" else None,
            accel_lsb_per_g=ChainImu.from_scenario(scenario).accel_lsb_per_g,
            alignment_window_s=alignment_window_s(scenario),
        )


def parse_schedule(text: str, setup: FirmwareSetup) -> UpdateSchedule | None:
    """``None`` for the recorded schedule, else the imposed :class:`UpdateSchedule`."""
    parts = text.split(":")
    mode = parts[0]
    try:
        if mode == "recorded" and len(parts) == 1:
            return None
        if mode == "config" and len(parts) == 1:
            return setup.config_schedule
        if mode in ("continuous", "none") and len(parts) == 1:
            return UpdateSchedule(mode)
        if mode == "windowed" and len(parts) == 3:
            u, t = float(parts[1]), float(parts[2])
            if u > 0 and t >= 0 and math.isfinite(u + t):
                return UpdateSchedule("windowed", update_s=u, timeout_s=t)
        if mode == "single" and len(parts) == 2:
            r = float(parts[1])
            if 0 < r <= 1000:
                return UpdateSchedule("single", single_rate_hz=r)
    except ValueError:
        pass
    raise NodesimError(f"--schedule {text!r}: allowed {SCHEDULE_HELP} (UPDATE_S > 0, TIMEOUT_S >= 0, 0 < RATE_HZ <= 1000)")


def allan_noise_of(node: NodeLog, window_s: float | None = None, slope_tolerance: float = 0.05) -> AllanNoise:
    """ARW and bias instability of the node's z gyro from the overlapping Allan deviation
    (:mod:`nodesim.sensors.allan`) of its samples, over the first ``window_s`` seconds (all samples if None);
    ``slope_tolerance``: how far from -1/2 a point of the ARW line may be (:func:`nodesim.sensors.allan.read_noise`)."""
    t = node.t_s
    sel = slice(None) if window_s is None else t < t[0] + window_s
    rate, ts = node.gyro_rad_s[sel, 2], t[sel]
    if rate.size < 100:
        raise NodesimError(f"Allan noise: node {node.node_id} has {rate.size} gyro samples in the window; allowed >= 100")
    dt = float(np.median(np.diff(ts)))
    return read_noise(overlapping_adev(rate, dt), slope_tolerance=slope_tolerance)


@dataclass(frozen=True)
class NodeReplay:
    """Firmware outputs of one replayed node, arrays (K,) at its ticks (NaN where the firmware gives none)."""

    node_id: int
    t_s: np.ndarray
    yaw_rad: np.ndarray
    yaw_var_rad2: np.ndarray
    bias_rad_s: np.ndarray
    inclination_rad: np.ndarray  # moving-averaged
    azimuth_rad: np.ndarray
    update: np.ndarray  # bool: reference update applied
    running: np.ndarray  # bool: filter running (time update done)
    encoder_rad: np.ndarray  # latest encoder reading at the tick (NaN without)
    held_ticks: int
    overflows: dict = field(default_factory=dict)
    frames: np.ndarray | None = None  # (K, 27) uint8 the estimate frames it encoded where the log records one sent


def _per_tick(node: NodeLog, ticks: np.ndarray, name: str) -> np.ndarray:
    """Recorded per-tick column: the last finite value among the rows in (t_{k-1}, t_k], NaN if none."""
    out = np.full(ticks.size, np.nan)
    v = node.extra[name].astype(float)
    ok = np.isfinite(v)
    k = np.searchsorted(ticks, node.t_s[ok], side="left")
    inside = k < ticks.size
    out[k[inside]] = v[ok][inside]
    return out


def recorded_frames(node: NodeLog, ticks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(frames (K, 27) uint8, source row index (K,), -1 where none): the estimate frame the log records at each
    tick (the row in (t_{k-1}, t_k] that has one)."""
    frames, src = np.zeros((ticks.size, fr.ESTIMATE_BYTES), np.uint8), np.full(ticks.size, -1, np.int64)
    rows = np.flatnonzero(node.extra["frame"][:, 0] != 0)
    k = np.searchsorted(ticks, node.t_s[rows], side="left")
    inside = k < ticks.size
    frames[k[inside]], src[k[inside]] = node.extra["frame"][rows[inside]], rows[inside]
    return frames, src


def tick_times(node: NodeLog, rate_hz: float) -> np.ndarray:
    if node.has("tick"):
        ticks = node.t_s[node.extra["tick"]]
    else:
        n = int(math.floor((node.t_s[-1] - node.t_s[0]) * rate_hz + 1e-9)) + 1
        ticks = node.t_s[0] + np.arange(n) / rate_hz
    if ticks.size < 2:
        raise NodesimError(f"node {node.node_id}: {ticks.size} firmware tick(s) in the log; allowed >= 2")
    return ticks


def encoder_at(node: NodeLog, ticks: np.ndarray) -> np.ndarray:
    """Latest finite encoder reading at or before each tick (NaN before the first reading)."""
    if node.encoder_rad is None:
        return np.full(ticks.size, np.nan)
    ok = np.isfinite(node.encoder_rad)
    te, ve = node.t_s[ok], node.encoder_rad[ok]
    i = np.searchsorted(te, ticks, side="right") - 1
    return np.where(i >= 0, ve[np.maximum(i, 0)], np.nan)


def references(node: NodeLog, ticks: np.ndarray, enc: np.ndarray, schedule: UpdateSchedule | None, setup: FirmwareSetup,
               t_log: float, is_top: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(scheduled mask, reference yaw, reference variance) per tick."""
    has_rec = node.has("ref_update")
    if has_rec:
        rec = _per_tick(node, ticks, "ref_update") == 1.0
        ref = np.where(rec, _per_tick(node, ticks, "ref_yaw"), np.nan)
        var = np.where(rec, _per_tick(node, ticks, "ref_var"), np.nan)
    else:
        rec = np.zeros(ticks.size, dtype=bool)
        ref = var = np.full(ticks.size, np.nan)
    if schedule is None:
        if not has_rec:
            raise NodesimError(f"node {node.node_id}: the log records no reference updates (column ref_update); "
                               f"impose a schedule: {SCHEDULE_HELP}")
        return rec, ref, var
    mask = np.array(schedule.mask(ticks - t_log, 1.0 / setup.rate_hz))  # a writable copy (the mask may be a broadcast)
    if is_top:
        use_enc = mask & ~rec
        if np.any(use_enc & ~np.isfinite(enc)):
            k = int(np.flatnonzero(use_enc & ~np.isfinite(enc))[0])
            raise NodesimError(f"node {node.node_id}: schedule '{schedule.describe()}' needs an encoder reading at tick {k} "
                               f"(t = {ticks[k]:.6g} s) and the log has none before it; allowed --schedule none")
        ref = np.where(use_enc, enc, ref)
        var = np.where(use_enc, setup.encoder_variance_rad2, var)
        return mask, ref, var
    return mask & rec, ref, var


def _tick_plan(node: NodeLog, setup: FirmwareSetup, schedule: UpdateSchedule | None, t_log: float, is_top: bool):
    """What both replays (float filter, fixed firmware) decide per tick before running: (ticks, ticks without a
    sample, encoder reading, update mask, reference yaw, reference variance, static window, hold)."""
    ticks = tick_times(node, setup.rate_hz)
    edges = np.searchsorted(node.t_s, np.concatenate([[2 * ticks[0] - ticks[1]], ticks]), side="right")
    held = int(np.count_nonzero(np.diff(edges) == 0))
    enc = encoder_at(node, ticks)
    mask, ref, var = references(node, ticks, enc, schedule, setup, t_log, is_top)
    static = (_per_tick(node, ticks, "static") == 1.0) if node.has("static") else ticks < t_log + setup.bias_window_s
    hold = (_per_tick(node, ticks, "hold") == 1.0) if node.has("hold") else np.zeros(ticks.size, dtype=bool)
    return ticks, held, enc, mask, ref, var, static, hold


def _alignment_ticks(setup: FirmwareSetup, t_log: float, ticks: np.ndarray) -> tuple[int, int]:
    """The alignment window's ticks (:func:`nodesim.chain.estimator.alignment_ticks`) at ``t_log`` + its times."""
    w = setup.alignment_window_s
    return alignment_ticks(None if w is None else (t_log + w[0], t_log + w[1]), ticks)


def replay_node(node: NodeLog, setup: FirmwareSetup, schedule: UpdateSchedule | None, t_log: float, is_top: bool,
                hold_gaps: bool = False) -> NodeReplay:
    """Run the firmware over one node's samples (see the module docstring)."""
    if setup.firmware is not None:
        return replay_node_firmware(node, setup, schedule, t_log, is_top, hold_gaps)
    ticks, held, enc, mask, ref, var, static, hold = _tick_plan(node, setup, schedule, t_log, is_top)
    both = np.concatenate([node.gyro_rad_s[:, 2:3], node.accel_m_s2], axis=1)
    avg = average_per_tick(node.t_s, both, ticks, hold_empty=hold_gaps)
    gyro, force = avg[:, 0], avg[:, 1:]
    K = ticks.size
    yaw, pvar, bias = np.full(K, np.nan), np.full(K, np.nan), np.full(K, np.nan)
    applied, running = np.zeros(K, dtype=bool), np.zeros(K, dtype=bool)
    no_enc = node.encoder_rad is None
    bias_sum, bias_n, kf = np.zeros(1), 0, None
    for k in range(K):
        if static[k]:
            bias_sum += gyro[k : k + 1]
            bias_n += 1
            yaw[k] = 0.0 if no_enc else enc[k]
            continue
        if kf is None:
            y0 = 0.0 if no_enc else enc[k]  # no encoder: the yaw is relative to the start
            kf = make_yaw_filter(setup.implementation, setup.filter_config, 1, np.array([y0]),
                                 bias_sum / bias_n if bias_n else 0.0, formats=setup.formats)
        elif not hold[k]:
            kf.predict(gyro[k : k + 1])
            if mask[k]:
                kf.update(ref[k : k + 1], var[k : k + 1])
                applied[k] = True
            running[k] = True
        yaw[k], pvar[k], bias[k] = kf.yaw_rad[0], kf.yaw_variance_rad2[0], kf.bias_rad_s[0]
    inc, azi = np.full(K, np.nan), np.full(K, np.nan)
    have = np.isfinite(yaw)
    if have.any():
        first = int(np.argmax(have))
        lo, hi = _alignment_ticks(setup, t_log, ticks[first:])
        averaged_surveys(np.ascontiguousarray(force[None, first:]), yaw[None, first:], lo, hi,
                         setup.moving_average_points, inc[None, first:], azi[None, first:])  # as a chain run does
    return NodeReplay(node.node_id, ticks, yaw, pvar, bias, inc, azi, applied, running, enc, held,
                      kf.overflow_counts if kf is not None else {})


def gyro_tick_counts(node: NodeLog, ticks: np.ndarray, cfg: FirmwareConfig, hold_gaps: bool) -> tuple[np.ndarray, np.ndarray]:
    """(z-gyro count sum (K,), samples (K,)) the firmware reads at each tick: the log's ``gyro_sum_z`` and
    ``samples`` where it records them (a simulated run), else the samples' int16 counts summed per tick
    (:func:`nodesim.sensors.imu.sum_per_tick`), a sample in SI units requantised to the configured ADC
    (``sensor.gyro_full_scale_dps``: ``rint(rate [deg/s] x LSB per deg/s)``, clipped to int16)."""
    if node.has("gyro_sum_z") and node.has("samples"):
        gz, n = _per_tick(node, ticks, "gyro_sum_z"), _per_tick(node, ticks, "samples")
        bad = ~(np.isfinite(gz) & np.isfinite(n) & (n >= 1))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise NodesimError(f"node {node.node_id}: tick {k} (t = {ticks[k]:.6g} s) has no gyro_sum_z / samples "
                               f"(samples >= 1 needed on every tick row)")
        return gz.astype(np.int64), n.astype(np.int64)
    lsb = GYRO_LSB_PER_DEG_S[cfg.gyro_full_scale_dps]
    counts = np.clip(np.rint(node.gyro_rad_s[:, 2] * (180.0 / math.pi) * lsb), -32768, 32767).astype(np.int64)
    sums, n = sum_per_tick(node.t_s, counts[:, None], ticks, hold_empty=hold_gaps)
    return sums[:, 0], n


def accel_tick_counts(node: NodeLog, ticks: np.ndarray, lsb_per_g: float, hold_gaps: bool) -> np.ndarray:
    """(K, 3) accelerometer count sums per tick: the log's ``accel_sum_*`` where it records them, else the samples'
    int16 counts (``rint(f / g0 x LSB per g)``, clipped) summed per tick."""
    names = ("accel_sum_x", "accel_sum_y", "accel_sum_z")
    if all(node.has(c) for c in names):
        sums = np.stack([_per_tick(node, ticks, c) for c in names], -1)
        if not np.isfinite(sums).all():
            k = int(np.flatnonzero(~np.isfinite(sums).all(-1))[0])
            raise NodesimError(f"node {node.node_id}: tick {k} (t = {ticks[k]:.6g} s) has no accel_sum_* value")
        return sums.astype(np.int64)
    counts = np.clip(np.rint(node.accel_m_s2 / G0_M_S2 * lsb_per_g), -32768, 32767).astype(np.int64)
    return sum_per_tick(node.t_s, counts, ticks, hold_empty=hold_gaps)[0]


def replay_node_firmware(node: NodeLog, setup: FirmwareSetup, schedule: UpdateSchedule | None, t_log: float,
                         is_top: bool, hold_gaps: bool = False) -> NodeReplay:
    """The fixed-point replay: the node firmware itself (:func:`firmware_model.node_firmware.node_tick`, as the
    chain's engines run it) fed the tick's gyro counts, every reference given to it as a direct update
    (``DIRECT_REF``: the recorded references are the firmware's own words after the eq 3.29 advance, so
    ``rint(ref / 2 pi x 2^32)`` and ``rint(var x (180/pi)^2 x 2^F)`` give them back exactly)."""
    cfg = setup.firmware
    ticks, held, enc, mask, ref, var, static, hold = _tick_plan(node, setup, schedule, t_log, is_top)
    gz, n = gyro_tick_counts(node, ticks, cfg, hold_gaps)
    accel = accel_tick_counts(node, ticks, setup.accel_lsb_per_g, hold_gaps)
    ref_raw = cfg.encoder_yaw_raw(np.where(mask, ref, 0.0))
    var_raw = np.asarray(fxp.from_float(np.where(mask, var, 0.0) * fk.RAD2_TO_DEG2, cfg.formats.p_yy,
                                        overflow=fxp.Overflow.SATURATE).raw, dtype=np.int64).reshape(-1)
    K = ticks.size
    yaw, pvar, bias = np.full(K, np.nan), np.full(K, np.nan), np.full(K, np.nan)
    applied, running = np.zeros(K, dtype=bool), np.zeros(K, dtype=bool)
    no_enc = node.encoder_rad is None
    fw = FirmwareLanes(cfg, 1)
    yaw_word = np.zeros(K, np.int64)
    # the log's send schedule: where the node sent a frame, the replay sends its own (the ticks since power-up as seq)
    sends = recorded_frames(node, ticks)[1] >= 0 if node.has("frame") else np.zeros(K, dtype=bool)
    frames = np.zeros((K, fr.ESTIMATE_BYTES), np.uint8) if node.has("frame") else None
    for k in range(K):
        if static[k]:  # the static window reports the encoder's yaw, as the chain's firmware does
            fw.tick(nf.STATIC, gz[k], n[k])
            yaw[k] = 0.0 if no_enc else enc[k]
            yaw_word[k] = 0 if no_enc else cfg.encoder_yaw_raw(enc[k])
            continue
        if fw.states[0, nf.S_RUNNING] == 0:
            fw.tick(nf.START, gz[k], n[k], yaw0_raw=0 if no_enc else cfg.encoder_yaw_raw(enc[k]))
        elif hold[k]:
            fw.tick(nf.HOLD, gz[k], n[k])
        else:
            fw.tick(nf.RUN, gz[k], n[k], ref=nf.DIRECT_REF if mask[k] else nf.NO_REF, ref_yaw_raw=ref_raw[k],
                    ref_aux_raw=var_raw[k])
            applied[k] = mask[k]
            running[k] = True
        yaw[k], pvar[k], bias[k] = fw.yaw_rad[0], fw.yaw_variance_rad2[0], fw.bias_rad_s[0]
        yaw_word[k] = fw.yaw_raw[0]
        if sends[k]:
            frames[k] = estimate_frame(node.node_id, k, timer_us(ticks[k]), fw.yaw_raw, fw.var_raw,
                                       fw.outputs[:, nf.OUT_RATE], fw.states[:, fk.I_BIAS])[0]
    # the survey as the chain's fixed firmware resolves it (nodesim.chain.network._node_run)
    inc_raw, azi_raw = np.zeros((1, K), np.int64), np.zeros((1, K), np.int64)
    lo, hi = _alignment_ticks(setup, t_log, ticks)
    node_survey.fixed_surveys(np.ascontiguousarray(accel[None]), yaw_word[None], n, lo, hi,
                              setup.moving_average_points, cfg.survey_mode, cfg.cordic_iterations, inc_raw, azi_raw,
                              cfg.formats.yaw.frac_bits)
    inc, azi = node_survey.inclination_rad(inc_raw)[0], node_survey.azimuth_rad(azi_raw)[0]
    return NodeReplay(node.node_id, ticks, yaw, pvar, bias, inc, azi, applied, running, enc, held, fw.overflow_counts,
                      frames)


def replay_log(log: ReplayLog, setup: FirmwareSetup, schedule: UpdateSchedule | None) -> tuple[NodeReplay, ...]:
    """Replay every node; the lowest node id is the top (encoder-aided) node."""
    t_log = min(float(n.t_s[0]) for n in log.nodes)
    top = min(n.node_id for n in log.nodes)
    if schedule is not None and schedule.mode != "none" and not log.meta.has_encoder:
        recorded = all(n.has("ref_update") for n in log.nodes)
        if not recorded:
            raise NodesimError(f"{log.path}: the log has no encoder (encoder_unit = absent) and no recorded references; "
                               f"schedule '{schedule.describe()}' needs one; allowed --schedule none")
    return tuple(replay_node(n, setup, schedule, t_log, n.node_id == top, log.hold_gaps) for n in log.nodes)


__all__ = ["FirmwareSetup", "NodeReplay", "parse_schedule", "replay_log", "replay_node", "allan_noise_of", "SCHEDULE_HELP"]
