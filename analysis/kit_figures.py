"""Figures of kits and tray designs: a plan orienting a kit, animated (GIF), and the design's Pareto plot.

The animation draws every compartment side by side (to scale) with up to ``max_parts`` trials of
direct simulation each, every part at its rest pose after every tilt (the poses
:func:`~analysis.montecarlo.run_direct` records); the frames between two rests fade from one rest
to the next (they are not the path the part slid: only the rests are simulated results). It is
written by matplotlib's animation module through Pillow.
"""
from __future__ import annotations

import numpy as np

__all__ = ["animate_kit", "pareto_figure"]

_BLUE = (0.12, 0.47, 0.71)
#: arrows of the tilts: the downhill direction of each action (unit vector)
_ARROW = {"N": (0, 1), "NE": (1, 1), "E": (1, 0), "SE": (1, -1), "S": (0, -1), "SW": (-1, -1), "W": (-1, 0),
          "NW": (-1, 1)}


def _outlines(shape_vertices, poses):
    """The polygon of every pose ``(x, y, theta)`` (NaN poses dropped)."""
    ok = np.all(np.isfinite(poses), axis=1)
    p = poses[ok]
    c, s = np.cos(p[:, 2]), np.sin(p[:, 2])
    v = np.asarray(shape_vertices)
    x = p[:, None, 0] + c[:, None] * v[None, :, 0] - s[:, None] * v[None, :, 1]
    y = p[:, None, 1] + s[:, None] * v[None, :, 0] + c[:, None] * v[None, :, 1]
    return np.stack([x, y], axis=2)


def animate_kit(results, scenes, names, path, *, max_parts: int = 300, hold: int = 3, fade: int = 2,
                fps: int = 5) -> str:
    """Write an animated GIF of a kit's direct simulation under one sequence.

    Parameters
    ----------
    results : list of DirectResult
        One per compartment (:func:`analysis.kit_replay.simulate_kit`), the same sequence.
    scenes : list of Scene
        The compartments' scenes (tray sizes, shapes).
    names : list of str
        Compartment names (panel titles).
    path : str
        Where the GIF goes.
    max_parts : int
        Trials drawn per compartment (the first ones).
    hold, fade : int
        Frames each rest is held, and frames of the fade to the next rest.
    fps : int
        Frames per second.

    Returns
    -------
    str
        ``path``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation, PillowWriter
    from matplotlib.collections import PolyCollection

    widths = [s.tray_x_mm for s in scenes]
    fig, axes = plt.subplots(1, len(scenes), figsize=(min(12.0, 2.2 + 2.4 * len(scenes)), 3.2),
                             gridspec_kw={"width_ratios": widths}, squeeze=False)
    axes = axes[0]
    colls, outlines = [], []
    for ax, scene, res, name in zip(axes, scenes, results, names):
        ax.set_xlim(-2, scene.tray_x_mm + 2)
        ax.set_ylim(-2, scene.tray_y_mm + 2)
        ax.set_aspect("equal")
        ax.axis("off")
        ax.add_patch(plt.Rectangle((0, 0), scene.tray_x_mm, scene.tray_y_mm, fill=False, lw=2, color="0.3"))
        ax.set_title(f"{name} ({scene.shape.name})", fontsize=8)
        steps = [_outlines(scene.shape.vertices, res.poses[:max_parts, k, :]) for k in range(res.poses.shape[1])]
        outlines.append(steps)
        coll = PolyCollection(list(steps[0]), facecolor=[_BLUE + (0.08,)], edgecolor=(0.0, 0.0, 0.5, 0.25), lw=0.4)
        ax.add_collection(coll)
        colls.append(coll)
    seq = list(results[0].sequence_names) if hasattr(results[0], "sequence_names") else []
    n_steps = results[0].poses.shape[1]
    frames = [f for k in range(n_steps) for f in ([(k, 1.0)] * hold
                                                   + ([(k + 1, (j + 1) / (fade + 1)) for j in range(fade)]
                                                      if k + 1 < n_steps else []))]
    title = fig.suptitle("", fontsize=10)

    def draw(frame):
        k, weight = frame
        for coll, steps in zip(colls, outlines):
            if weight >= 1.0:
                coll.set_verts(list(steps[k]))
                coll.set_facecolor([_BLUE + (0.08,)])
            else:                       # fading in the next rest over the previous one
                coll.set_verts(list(steps[k - 1]) + list(steps[k]))
                alphas = [0.08 * (1 - weight)] * len(steps[k - 1]) + [0.08 * weight] * len(steps[k])
                coll.set_facecolor([_BLUE + (a,) for a in alphas])
        action = seq[k - 1] if 0 < k <= len(seq) else None
        text = "start: uniform random poses" if k == 0 else f"after tilt {k} of {n_steps - 1}: {action}"
        if action in _ARROW and weight >= 1.0:
            dx, dy = _ARROW[action]
            text += "  " + {(0, 1): "↑", (1, 1): "↗", (1, 0): "→", (1, -1): "↘", (0, -1): "↓", (-1, -1): "↙",
                            (-1, 0): "←", (-1, 1): "↖"}[(dx, dy)]
        title.set_text(text)
        return colls

    fig.tight_layout()
    anim = FuncAnimation(fig, draw, frames=frames, blit=False)
    anim.save(path, writer=PillowWriter(fps=fps), dpi=72)
    plt.close(fig)
    return str(path)


def pareto_figure(design: dict, path) -> str:
    """The design's variants: plan length and expected random tilts against tray area, the Pareto
    front joined and the best variant marked.

    Parameters
    ----------
    design : dict
        ``kruskal design``'s result (``variants``, ``pareto_plan``, ``pareto_tilts``, ``best``).
    path : str
        Where the PNG goes.

    Returns
    -------
    str
        ``path``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = design["variants"]
    area = np.array([r["area_mm2"] / 100.0 for r in rows])
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    tilts = sorted({r["tilt_deg"] for r in rows})
    colors = plt.cm.viridis(np.linspace(0, 0.85, max(1, len(tilts))))
    for ax, key, front, label in ((axes[0], "plan_length", design["pareto_plan"], "shortest common plan (tilts)"),
                                  (axes[1], "expected_tilts", design["pareto_tilts"], "expected random tilts")):
        for t, color in zip(tilts, colors):
            idx = [i for i, r in enumerate(rows) if r["tilt_deg"] == t and r[key] is not None]
            ax.plot(area[idx], [rows[i][key] for i in idx], "o", color=color, label=f"tilt {t:g} deg")
            if key == "expected_tilts":
                for i in idx:
                    lo, hi = rows[i]["expected_tilts_ci"]
                    if lo is not None:
                        ax.plot([area[i]] * 2, [lo, hi], "-", color=color, lw=1)
        pts = sorted((area[i], rows[i][key]) for i in front if rows[i][key] is not None)
        if pts:
            ax.step([p[0] for p in pts], [p[1] for p in pts], where="post", color="tab:red", lw=1,
                    label="Pareto front")
        b = design["best"]
        if b is not None and rows[b][key] is not None:
            ax.plot(area[b], rows[b][key], "*", ms=16, mfc="none", mec="tab:red", label="best")
        ax.set_xlabel("tray area (cm^2, all compartments)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        if key == "plan_length":
            ax.yaxis.get_major_locator().set_params(integer=True)
    axes[0].legend(fontsize=7)
    never = [r for r in rows if r["plan_length"] is None and r["expected_tilts"] is None]
    if never:
        names = ", ".join(sorted({"kit's own" if r["tray_mm"] is None else f"{r['tray_mm'][0]:g} x {r['tray_mm'][1]:g}"
                                  for r in never}))
        fig.text(0.01, 0.01, f"not shown: {len(never)} variant(s) that never orient every part ({names} mm)",
                 fontsize=7, color="0.3")
    fig.suptitle(f"tray design for {design.get('source', '')} (target {design.get('target', 'cell')})", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)
