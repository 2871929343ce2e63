"""Meshcat animation of a trajectory: keyframes per body, resampled to the display rate.

A run integrated with small steps may hold 10^5 samples; the viewer only needs the frames
it will show.  The trajectory is resampled at ``fps`` frames per second of *playback*
(``slowdown`` seconds of playback per simulated second), capped at ``max_frames``; the
configuration between two samples is interpolated on the configuration manifold
(``pin.interpolate``), so spherical joints' quaternions stay unit.  Each body gets a
position and a quaternion track (three.js order x, y, z, w); clearance arrows also get a
scale track.  Contact forces are impulsive (an impact lasts about a millisecond), so a
frame's force arrows show the stored sample of largest normal force within the frame's time
window (peak hold) rather than the nearest sample.  Meshcat's time slider shows playback
seconds: simulated time is ``t0 + slider / slowdown``.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin
from meshcat.animation import Animation, AnimationClip, AnimationTrack
from scipy.spatial.transform import Rotation

from pinclear.model.kinematics import frame_motion
from pinclear.viz.scene import MechanismScene, arrow_matrix


def resample(model: pin.Model, t: np.ndarray, q: np.ndarray, fps: float = 30.0,
             slowdown: float = 1.0, max_frames: int = 1500):
    """Frames of a trajectory at the display rate.

    Returns ``(t_frames, q_frames, nearest, fps_eff)``: simulated times of the frames, the
    interpolated configurations, the index of the nearest stored sample (for per-sample
    outputs such as contact forces) and the playback frame rate actually used.
    """
    t = np.asarray(t, float)
    q = np.asarray(q, float)
    if slowdown <= 0 or fps <= 0 or max_frames < 2:
        raise ValueError(f"slowdown and fps must be > 0 and max_frames >= 2 "
                         f"(got slowdown={slowdown}, fps={fps}, max_frames={max_frames})")
    if len(t) == 1:
        return t.copy(), q.copy(), np.zeros(1, int), float(fps)
    play = (t[-1] - t[0]) * slowdown
    n = int(min(max_frames, np.floor(play * fps + 1e-9) + 1))
    n = max(n, 2)
    fps_eff = (n - 1) / play if play > 0 else fps
    tf = t[0] + np.arange(n) / (fps_eff * slowdown)
    tf[-1] = min(tf[-1], t[-1])
    i = np.clip(np.searchsorted(t, tf, side="right") - 1, 0, len(t) - 2)
    dt = t[i + 1] - t[i]
    alpha = np.where(dt > 0, (tf - t[i]) / np.where(dt > 0, dt, 1.0), 0.0)
    alpha = np.clip(alpha, 0.0, 1.0)
    qf = np.array([pin.interpolate(model, q[a], q[a + 1], float(s)) for a, s in zip(i, alpha)])
    nearest = np.where(alpha < 0.5, i, i + 1)
    return tf, qf, nearest, float(fps_eff)


def _tracks_from_matrices(T: np.ndarray, with_scale: bool = False) -> dict:
    """position / quaternion (/ scale) keyframe values from stacked 4x4 transforms."""
    A = T[:, :3, :3]
    out = {"position": T[:, :3, 3]}
    if with_scale:
        s = np.linalg.norm(A, axis=1)           # column norms
        out["scale"] = s
        A = A / np.where(s > 0, s, 1.0)[:, None, :]
    out["quaternion"] = Rotation.from_matrix(A).as_quat()   # x, y, z, w as three.js wants
    return out


_JSTYPE = {"position": "vector3", "quaternion": "quaternion", "scale": "vector3"}


def _clip(values: dict, fps: float) -> AnimationClip:
    frames = list(range(len(next(iter(values.values())))))
    clip = AnimationClip(fps=fps)
    for name, arr in values.items():
        clip.tracks[name] = AnimationTrack(name, _JSTYPE[name], frames=list(frames),
                                           values=[list(map(float, v)) for v in arr])
    return clip


def _force_norm(outputs: dict, name: str):
    f = outputs.get(f"{name}.normal_force")
    return np.linalg.norm(f, axis=1) if f is not None and np.ndim(f) == 2 else None


def peak_samples(t: np.ndarray, tf: np.ndarray, mag: np.ndarray | None, nearest: np.ndarray):
    """Per frame, the stored sample of largest ``mag`` within the frame's time window (half way
    to the neighbouring frames): an impact shorter than a frame still shows at its peak."""
    if mag is None or len(tf) < 2:
        return nearest
    mid = 0.5 * (tf[1:] + tf[:-1])
    lo = np.searchsorted(t, np.concatenate(([-np.inf], mid)), side="left")
    hi = np.searchsorted(t, np.concatenate((mid, [np.inf])), side="left")
    out = np.array(nearest, copy=True)
    for k in range(len(tf)):
        if hi[k] > lo[k]:
            w = mag[lo[k]:hi[k]]
            if np.any(w > 0):
                out[k] = lo[k] + int(np.argmax(w))
    return out


def platform_positions(scene: MechanismScene, qs: np.ndarray) -> np.ndarray | None:
    fid = getattr(scene.mech, "platform_frame", None)
    if fid is None:
        return None
    return frame_motion(scene.model, [fid], qs).p[:, 0]


def prescribed_positions(mech, times: np.ndarray) -> np.ndarray | None:
    """World positions of the prescribed platform motion, if the mechanism has one
    (``mech.platform_motion(t) -> pin.SE3``, docs/design.md 'platform.motion')."""
    f = getattr(mech, "platform_motion", None)
    if f is None or not callable(f):
        return None
    out = []
    for t in times:
        M = f(float(t))
        M = M[0] if isinstance(M, tuple) else M      # (pose, twist, ...) is accepted too
        out.append(np.asarray(M.translation, float))
    return np.array(out)


def auto_slowdown(duration: float, min_playback: float = 5.0) -> float:
    """Real time, unless the run is shorter than ``min_playback`` seconds: then slowed by a
    round factor (1, 2, 5 x 10^k) so that it plays for at least that long."""
    if duration <= 0 or duration >= min_playback:
        return 1.0
    need = min_playback / duration
    k = np.floor(np.log10(need))
    for m in (1.0, 2.0, 5.0, 10.0):
        if m * 10**k >= need:
            return float(m * 10**k)
    return float(10 ** (k + 1))


def animate(scene: MechanismScene, traj, *, fps: float = 30.0, slowdown: float | None = 1.0,
            max_frames: int = 1500, play: bool = True, loop: bool = False) -> dict:
    """Attach an animation of ``traj`` to ``scene`` (meshcat time slider); returns the
    frame bookkeeping that is also stored in ``scene.info['animation']``.
    ``slowdown=None``: :func:`auto_slowdown`."""
    if slowdown is None:
        slowdown = auto_slowdown(float(traj.t[-1] - traj.t[0]))
    tf, qf, nearest, fps_eff = resample(scene.model, traj.t, traj.q, fps, slowdown, max_frames)
    outputs = getattr(traj, "outputs", None) or {}
    nb = len(scene.body_paths)
    Tb = np.empty((len(tf), nb, 4, 4))
    Ta = {}
    force_max = 0.0
    vecs = []
    peak = [peak_samples(traj.t, tf, _force_norm(outputs, el.name), nearest) for el in scene.clearances]
    for k, q in enumerate(qf):
        Tb[k] = scene.body_transforms(q)
        vk = scene.clearance_vectors(q, outputs, [int(p[k]) for p in peak])
        vecs.append(vk)
        for (_, _, fn, ft) in vk:
            force_max = max(force_max, float(np.linalg.norm(fn)), float(np.linalg.norm(ft)))
    if scene.info["force_scale"] is None:
        # longest force arrow = a quarter of the mechanism (stated in the legend)
        scene.info["force_scale"] = 0.25 * scene.size / force_max if force_max > 0 else 0.0
    fs, es = scene.info["force_scale"], scene.info["ecc_scale"]
    for c, el in enumerate(scene.clearances):
        for part in ("eccentricity", "normal_force", "friction_force"):
            Ta[(el.name, part)] = np.empty((len(tf), 4, 4))
        for k in range(len(tf)):
            p1, e, fn, ft = vecs[k][c]
            Ta[(el.name, "eccentricity")][k] = arrow_matrix(p1, es * e)
            Ta[(el.name, "normal_force")][k] = arrow_matrix(p1 + e, fs * fn)
            Ta[(el.name, "friction_force")][k] = arrow_matrix(p1 + e, fs * ft)

    anim = Animation(default_framerate=fps_eff)
    for j, path in enumerate(scene.body_paths):
        anim.clips[scene.root[path].path] = _clip(_tracks_from_matrices(Tb[:, j]), fps_eff)
    for (name, part), T in Ta.items():
        node = scene.root["overlays/clearance"][name][part]
        anim.clips[node.path] = _clip(_tracks_from_matrices(T, with_scale=True), fps_eff)

    # static overlays: the platform's path and the prescribed one, over the whole run
    stride = max(1, len(traj.t) // 4000)
    qs = np.asarray(traj.q)[::stride]
    trace = platform_positions(scene, qs)
    pres = prescribed_positions(scene.mech, np.asarray(traj.t)[::stride])
    scene.add_paths(trace, pres)

    scene.set_configuration(qf[0], outputs, int(nearest[0]))
    scene.vis.set_animation(anim, play=play, repetitions=(10**6 if loop else 1))
    info = {"frames": int(len(tf)), "fps": fps_eff, "slowdown": float(slowdown),
            "t0": float(tf[0]), "t1": float(tf[-1]), "samples": int(len(traj.t))}
    scene.info["animation"] = info
    return info


def frame_times(info: dict) -> np.ndarray:
    """Simulated times of the animation frames (from ``scene.info['animation']``)."""
    return info["t0"] + np.arange(info["frames"]) / (info["fps"] * info["slowdown"])


def loudest_frame_time(scene: MechanismScene, traj) -> float | None:
    """Simulated time of the frame that shows the largest contact force (peak-hold windows as
    in the animation); None without a recorded clearance force."""
    if "animation" not in scene.info:
        return None
    tf = frame_times(scene.info["animation"])
    best, t_best = 0.0, None
    for el in scene.clearances:
        mag = _force_norm(traj.outputs, el.name)
        if mag is None:
            continue
        near = np.clip(np.searchsorted(traj.t, tf), 0, len(traj.t) - 1)
        idx = peak_samples(np.asarray(traj.t), tf, mag, near)
        k = int(np.argmax(mag[idx]))
        if mag[idx][k] > best:
            best, t_best = float(mag[idx][k]), float(tf[k])
    return t_best
