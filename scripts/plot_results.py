#!/usr/bin/python3
"""Draws a run's figures from the files run_recorder wrote in a results folder.

    plot_results.py RESULTS_DIR

Reads summary.json, grids.json, trajectories.csv, gaps.csv, objects.csv, terrain_heights.npy
and rut_depth.npy, and writes trajectories.png (paths over a hillshade of the course), ruts.png
(rut depth map, cm) and gaps.png (gap to the leader along its path vs sim time). Exits 1 naming
the file that is missing or malformed, or that could not be written.
"""
import csv
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")  # headless: no display needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.cm import ScalarMappable  # noqa: E402
from matplotlib.colors import LightSource, LinearSegmentedColormap, Normalize  # noqa: E402
from matplotlib.patches import Polygon  # noqa: E402

DPI = 110
# One colour per vehicle, in the summary's order (colour-blind-safe Tableau/Okabe-Ito mix).
COLOURS = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#F0E442"]
OBJECT_STYLE = {  # face colour, label
    "building": ("#6b6b6b", "building"),
    "barrier": ("#9a8f80", "barrier"),
    "fence": ("#8c6d46", "fence"),
    "rock": ("#7f7f7f", "rock"),
    "tree": ("#2f6b2f", "tree"),
    "shrub": ("#6b9b3a", "shrub"),
    "pole": ("#444444", "pole"),
}


class InputError(Exception):
    pass


def load_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        raise InputError(f"{path}: {e}")


def load_csv(path):
    try:
        with open(path, newline="") as f:
            return list(csv.DictReader(f))
    except OSError as e:
        raise InputError(f"{path}: {e}")


def load_grid(folder, entry, name):
    """The .npy grid of a grids.json entry, with its geometry; None if the entry is null."""
    if entry is None:
        return None
    path = os.path.join(folder, entry["file"])
    try:
        values = np.load(path)
    except (OSError, ValueError) as e:
        raise InputError(f"{path}: {e}")
    if values.shape != (entry["height"], entry["width"]):
        raise InputError(f"{path}: shape {values.shape}, grids.json says "
                         f"({entry['height']}, {entry['width']}) for {name}")
    r = entry["resolution"]
    # imshow extent: cell edges (the origin is the centre of cell (0, 0)).
    extent = [entry["origin_x"] - r / 2, entry["origin_x"] + (entry["width"] - 0.5) * r,
              entry["origin_y"] - r / 2, entry["origin_y"] + (entry["height"] - 0.5) * r]
    return values, extent, r


def tracks_by_vehicle(rows):
    out = {}
    for row in rows:
        v = out.setdefault(row["vehicle"], {"t": [], "x": [], "y": [], "speed": []})
        for k in ("t", "x", "y", "speed"):
            v[k].append(float(row[k]))
    return {name: {k: np.array(a) for k, a in v.items()} for name, v in out.items()}


def save(fig, path):
    try:
        fig.savefig(path, dpi=DPI)
    except OSError as e:
        raise InputError(f"cannot write {path}: {e}")
    finally:
        plt.close(fig)


def map_figure(extent):
    """A figure whose map axes fit the extent's aspect (equal axes), with room for a colour bar."""
    aspect = (extent[3] - extent[2]) / max(1e-9, extent[1] - extent[0])
    width = 9.0
    height = min(max(width * aspect, 3.0), 8.0)
    if width * aspect > 8.0:
        width = max(8.0 / aspect, 4.5)
    return plt.subplots(figsize=(width + 2.6, height + 1.6), constrained_layout=True)


def fmt(value, unit="", digits=1):
    return "n/a" if value is None else f"{value:.{digits}f}{unit}"


def object_polygon(o):
    c, s = math.cos(o["yaw"]), math.sin(o["yaw"])
    hl, hw = o["length"] / 2, o["width"] / 2
    return [(o["x"] + c * a - s * b, o["y"] + s * a + c * b) for a, b in ((hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw))]


def plot_trajectories(folder, summary, terrain, tracks, objects):
    heights, extent, res = terrain
    fig, ax = map_figure(extent)
    z = np.ma.masked_invalid(heights)
    if z.count() > 0:
        filled = z.filled(float(z.min()))
        # Grey hillshade, tinted by height in land colours only (no blue that would read as water).
        cmap = LinearSegmentedColormap.from_list("land", plt.get_cmap("gist_earth")(np.linspace(0.35, 0.95, 256)))
        z_min, z_max = float(z.min()), float(z.max())
        if z_max - z_min < 0.1:  # flat: one colour, a scale of +-1 m around it rather than of rounding noise
            z_min, z_max = z_min - 1.0, z_max + 1.0
        norm = Normalize(vmin=z_min, vmax=z_max)
        shade = LightSource(azdeg=315, altdeg=45).hillshade(filled, vert_exag=3.0, dx=res, dy=res)
        ax.imshow(shade, cmap="gray", vmin=0.0, vmax=1.0, origin="lower", extent=extent, interpolation="bilinear")
        ax.imshow(filled, cmap=cmap, norm=norm, alpha=0.45, origin="lower", extent=extent, interpolation="bilinear")
        bar = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), cax=ax.inset_axes([1.015, 0.0, 0.022, 1.0]))
        bar.set_label("terrain height, m (shaded from the north-west)")
        # Height contours so slopes read as numbers, not just shading.
        span = float(z.max() - z.min())
        if span > 0.5:
            step = 10 ** math.floor(math.log10(span / 4))
            step *= 5 if span / step > 20 else (2 if span / step > 8 else 1)
            ny, nx = heights.shape
            xs = extent[0] + res / 2 + res * np.arange(nx)
            ys = extent[2] + res / 2 + res * np.arange(ny)
            levels = np.arange(math.ceil(float(z.min()) / step) * step, float(z.max()), step)
            if len(levels) > 0:
                cs = ax.contour(xs, ys, z, levels=levels, colors="k", linewidths=0.4, alpha=0.45)
                ax.clabel(cs, fontsize=7, fmt="%g m")
    drawn = set()
    for o in objects:
        face, label = OBJECT_STYLE.get(o["type"], ("#555555", o["type"]))
        if o["type"] == "grass":
            continue
        toppled = o["toppled"] == "1"
        poly = Polygon(object_polygon({k: float(o[k]) for k in ("x", "y", "yaw", "length", "width")}), closed=True,
                       facecolor=face, edgecolor="k", linewidth=0.3, alpha=0.35 if toppled else 0.85,
                       hatch="xx" if toppled else None,
                       label=None if label in drawn else label)
        drawn.add(label)
        ax.add_patch(poly)
    vehicles = summary["vehicles"]
    # Followers drive in their leader's tracks: earlier vehicles are drawn wider, later ones
    # narrower on top, so every path stays visible where they coincide.
    n = len(vehicles)
    for k, v in enumerate(vehicles):
        width = 2.0 + 1.6 * (n - 1 - k)
        name = v["name"]
        colour = COLOURS[k % len(COLOURS)]
        tr = tracks.get(name)
        role = f", follows {v['leader']}" if v.get("leader") else ""
        label = f"{name}{role}: {fmt(v.get('distance'), ' m')}, mean {fmt(v.get('mean_speed'), ' m/s', 2)}"
        if tr is None or len(tr["x"]) == 0:
            ax.plot([], [], color=colour, label=label + " (no odometry)")
            continue
        ax.plot(tr["x"], tr["y"], color="white", linewidth=width + 1.6, alpha=0.8, solid_capstyle="round", zorder=2)
        ax.plot(tr["x"], tr["y"], color=colour, linewidth=width, label=label, solid_capstyle="round", zorder=3 + k)
        ax.plot(tr["x"][0], tr["y"][0], marker="o", markersize=9, color=colour, markeredgecolor="white",
                markeredgewidth=1.5, linestyle="none", zorder=20)
        ax.plot(tr["x"][-1], tr["y"][-1], marker="s", markersize=9, color=colour, markeredgecolor="black",
                markeredgewidth=1.5, linestyle="none", zorder=20)
    # Marker legend entries (shape only).
    ax.plot([], [], marker="o", color="grey", markeredgecolor="white", linestyle="none", markersize=8, label="start")
    ax.plot([], [], marker="s", color="grey", markeredgecolor="black", linestyle="none", markersize=8, label="end")
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_aspect("equal")
    ax.set_xlabel("map x (east), m")
    ax.set_ylabel("map y (north), m")
    ax.set_title(f"{summary['scenario']}: vehicle paths over the terrain (hillshade, height contours)\n"
                 f"{fmt(summary.get('sim_time_end'), ' s')} of sim time, real-time factor "
                 f"{fmt(summary.get('real_time_factor'), '', 2)}")
    ax.legend(loc="best", fontsize=8, framealpha=0.85)
    ax.grid(True, color="white", alpha=0.3, linewidth=0.5)
    save(fig, os.path.join(folder, "trajectories.png"))


def plot_ruts(folder, summary, ruts, terrain, tracks):
    fig, ax = map_figure(ruts[1] if ruts is not None else terrain[1])
    title = f"{summary['scenario']}: rut depth (undeformed minus deformed terrain height)"
    if ruts is None:
        heights, extent, _ = terrain
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.text(0.5, 0.5, "no ruts deeper than 2 mm were reported on /terrain/ruts", transform=ax.transAxes,
                ha="center", va="center", fontsize=13)
    else:
        depth, extent, res = ruts
        cm = np.ma.masked_invalid(depth * 100.0)
        # Undisturbed ground (|depth| < 1 mm) stays light grey so the ruts stand out; berms
        # (negative depth) show at the bottom of the scale.
        ax.set_facecolor("#e8e8e8")
        finite = depth[np.isfinite(depth)] * 100.0
        # The scale tops out at the 99.5th percentile (a few deepest cells would wash the rest
        # out); deeper cells show in the darkest colour, the bar's arrow says so.
        vmax = max(0.5, 1.1 * float(np.percentile(finite, 99.5))) if finite.size else 1.0
        vmin = min(0.0, float(finite.min())) if finite.size else 0.0
        shown = np.ma.masked_where(np.abs(cm.filled(0.0)) < 0.1, cm)
        im = ax.imshow(shown, origin="lower", extent=extent, cmap="inferno_r", vmin=vmin, vmax=vmax,
                       interpolation="nearest")
        bar = fig.colorbar(im, cax=ax.inset_axes([1.015, 0.0, 0.022, 1.0]),
                           extend="max" if finite.size and finite.max() > vmax else "neither")
        bar.set_label("rut depth, cm (negative: soil pushed up)")
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        for k, v in enumerate(summary["vehicles"]):
            tr = tracks.get(v["name"])
            if tr is not None and len(tr["x"]) > 0:
                ax.plot(tr["x"], tr["y"], color=COLOURS[k % len(COLOURS)], linewidth=0.8, alpha=0.7,
                        linestyle="--", label=f"{v['name']} path (base_link)")
        ax.legend(loc="best", fontsize=8, framealpha=0.85)
        r = summary.get("ruts", {})
        title += (f"\ndeepest {fmt(None if r.get('max_depth') is None else 100 * r['max_depth'], ' cm')}, "
                  f"{fmt(r.get('area_deeper_than_1cm'), ' m²')} deeper than 1 cm; cell {res:.2f} m "
                  f"(each cell shows the deepest point in it)")
    ax.set_aspect("equal")
    ax.set_xlabel("map x (east), m")
    ax.set_ylabel("map y (north), m")
    ax.set_title(title)
    save(fig, os.path.join(folder, "ruts.png"))


def plot_gaps(folder, summary, gap_rows):
    fig, ax = plt.subplots(figsize=(11, 5.5), constrained_layout=True)
    followers = [(k, v) for k, v in enumerate(summary["vehicles"]) if v.get("leader")]
    series = {}
    for row in gap_rows:
        s = series.setdefault(row["follower"], ([], []))
        s[0].append(float(row["t"]))
        s[1].append(float(row["gap"]))
    if not followers:
        ax.text(0.5, 0.5, "no vehicle follows another in this run", transform=ax.transAxes, ha="center",
                va="center", fontsize=13)
    for k, v in followers:
        t, g = series.get(v["name"], ([], []))
        label = (f"{v['name']} behind {v['leader']}: min {fmt(v.get('gap_min'), ' m')}, "
                 f"mean {fmt(v.get('gap_mean'), ' m')}")
        if not t:
            label += " (no data)"
        ax.plot(t, g, color=COLOURS[k % len(COLOURS)], linewidth=1.6, label=label)
    ax.set_xlabel("sim time, s")
    ax.set_ylabel("gap to leader along its path, m")
    ax.set_title(f"{summary['scenario']}: gap of each follower to its leader\n"
                 "(distance along the leader's driven path, base_link to base_link)")
    ax.grid(True, alpha=0.4)
    if followers:
        ax.legend(loc="best", fontsize=9)
        ax.set_ylim(bottom=0.0)
    save(fig, os.path.join(folder, "gaps.png"))


def main(argv):
    if len(argv) != 2:
        print("usage: plot_results.py RESULTS_DIR", file=sys.stderr)
        return 2
    folder = argv[1]
    try:
        summary = load_json(os.path.join(folder, "summary.json"))
        grids = load_json(os.path.join(folder, "grids.json"))
        terrain = load_grid(folder, grids.get("terrain"), "terrain")
        if terrain is None:
            raise InputError(os.path.join(folder, "grids.json") + ": no terrain grid")
        ruts = load_grid(folder, grids.get("ruts"), "ruts")
        tracks = tracks_by_vehicle(load_csv(os.path.join(folder, "trajectories.csv")))
        objects_path = os.path.join(folder, "objects.csv")
        objects = load_csv(objects_path) if os.path.exists(objects_path) else []
        gap_rows = load_csv(os.path.join(folder, "gaps.csv"))
        plot_trajectories(folder, summary, terrain, tracks, objects)
        plot_ruts(folder, summary, ruts, terrain, tracks)
        plot_gaps(folder, summary, gap_rows)
    except InputError as e:
        print(f"plot_results.py: {e}", file=sys.stderr)
        return 1
    except KeyError as e:
        print(f"plot_results.py: {folder}: a file lacks the key {e} (summary.json, grids.json or a CSV header)",
              file=sys.stderr)
        return 1
    except ValueError as e:
        print(f"plot_results.py: {folder}: a malformed value: {e}", file=sys.stderr)
        return 1
    print(f"plot_results.py: wrote trajectories.png, ruts.png, gaps.png in {folder}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
