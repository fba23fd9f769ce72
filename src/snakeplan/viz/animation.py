"""Videos of the arm crawling in along its path (mp4 through imageio-ffmpeg, GIF through Pillow), headless.

Each frame shows the scene in two views (as the plan figure does), the body with every link coloured by its
clearance (orange near a wall, green clear, pure red inside one), the tip path travelled so far above it, and a
progress bar of the insertion depth. From the frame of the judge's first failure on, a red banner names it and
a red cross marks the colliding link. The scene is drawn once; each frame restores it and draws only the moving
artists (matplotlib blitting on the Agg canvas), which keeps 200 frames well under half a minute on one core.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from snakeplan.files import atomic_path
from snakeplan.viz.crawl import CrawlFrames

#: Video formats by suffix.
FORMATS = (".mp4", ".gif")
#: Frame sizes (px) a user may ask for; both even (H.264 with yuv420p needs it).
MIN_SIZE, MAX_SIZE = 160, 3840
DEFAULT_SIZE = (960, 540)
DEFAULT_FRAMES, DEFAULT_FPS = 120, 30.0
#: Clearance (mm) at and above which a link is drawn fully green.
CLEAR_MM = 30.0
#: Colours of a GIF's one palette.
GIF_COLORS = 128
VIDEO_INSTALL = 'pip install "snakeplan[video]"'


def check_video_options(filename: str, frames: int, fps: float, size: tuple[int, int], field: str) -> None:
    """ValueError (naming ``field``, ``--frames``, ``--fps`` or ``--frame-size``) for options no video can have,
    and MissingExtra for an mp4 without imageio-ffmpeg; called before any work."""
    from snakeplan.viz.crawl import MAX_FRAMES, MIN_FRAMES

    if Path(filename).suffix.lower() not in FORMATS:
        raise ValueError(f"{field}: expected a .mp4 or .gif file, got {filename!r}")
    if not MIN_FRAMES <= frames <= MAX_FRAMES:
        raise ValueError(f"--frames: expected {MIN_FRAMES} to {MAX_FRAMES}, got {frames}")
    if not 0.5 <= fps <= 120.0:
        raise ValueError(f"--fps: expected 0.5 to 120 frames per second, got {fps:g}")
    w, h = size
    if not (MIN_SIZE <= w <= MAX_SIZE and MIN_SIZE <= h <= MAX_SIZE and w % 2 == 0 and h % 2 == 0):
        raise ValueError(f"--frame-size: expected WIDTHxHEIGHT, both even, {MIN_SIZE} to {MAX_SIZE} px, got {w}x{h}")
    if Path(filename).suffix.lower() == ".mp4":
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError:
            from snakeplan.extras import MissingExtra

            raise MissingExtra(f"{field}: mp4 needs imageio-ffmpeg: {VIDEO_INSTALL}", name="imageio_ffmpeg") from None


def clearance_colors(clearance: np.ndarray) -> np.ndarray:
    """RGBA ``(..., 4)`` per clearance (mm): pure red inside an obstacle, orange at contact to green at
    :data:`CLEAR_MM` and beyond."""
    from matplotlib import colormaps

    c = np.asarray(clearance, dtype=float)
    out = colormaps["RdYlGn"](0.3 + 0.6 * np.clip(c / CLEAR_MM, 0.0, 1.0))
    out[c < 0.0] = (1.0, 0.0, 0.0, 1.0)
    return out


def write_video(filename: str | Path, frames: Iterator[np.ndarray], count: int, fps: float,
                size: tuple[int, int]) -> Path:
    """Write ``count`` RGB frames ``(h, w, 3)`` uint8 as mp4 (H.264, yuv420p) or GIF, atomically."""
    out = Path(filename)
    with atomic_path(out) as tmp:
        if out.suffix.lower() == ".gif":
            from PIL import Image

            rgb = list(frames)
            # one palette for the whole video (from a few frames side by side), so that Pillow stores each frame
            # as its change from the one before: the scene's pixels never change
            sample = np.hstack([f[::2, ::2] for f in rgb[:: max(1, len(rgb) // 8)]] + [rgb[-1][::2, ::2]])
            palette = Image.fromarray(sample).quantize(colors=GIF_COLORS, dither=Image.Dither.NONE)
            images = [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in rgb]
            images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:], loop=0,
                           duration=int(round(1000.0 / fps)), optimize=False)
        else:
            import imageio_ffmpeg

            writer = imageio_ffmpeg.write_frames(str(tmp), size, fps=fps, codec="libx264", pix_fmt_in="rgb24",
                                                 pix_fmt_out="yuv420p", quality=7, macro_block_size=2,
                                                 ffmpeg_log_level="error", output_params=["-f", "mp4"])
            writer.send(None)
            for f in frames:
                writer.send(np.ascontiguousarray(f))
            writer.close()
    return out


def _progress(count: int, label: str) -> Callable[[], None]:
    """A progress bar on standard error (rich); returns the per-frame step and stops after ``count`` steps."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    bar = Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(), transient=True,
                   console=_stderr_console())
    task = bar.add_task(label, total=count)
    bar.start()
    done = [0]

    def step() -> None:
        done[0] += 1
        bar.advance(task)
        if done[0] >= count:
            bar.stop()

    return step


def _stderr_console():
    from rich.console import Console

    return Console(stderr=True)


def crawl_frames_rgb(frames: CrawlFrames, title: str, size: tuple[int, int] = DEFAULT_SIZE,
                     progress: bool = True) -> Iterator[np.ndarray]:
    """The video's RGB frames ``(h, w, 3)`` uint8, one per crawl frame, rendered as they are asked for."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from mpl_toolkits.mplot3d import proj3d

    from snakeplan.viz.scene_plot import COLLISION_COLOR, PATH_COLOR, draw_scene, set_flat_view

    scene = frames.scene
    w, h = size
    dpi = 100.0
    scale = min(w / DEFAULT_SIZE[0], h / DEFAULT_SIZE[1])  # text and lines shrink with the frame
    fig = Figure(figsize=(w / dpi, h / dpi), dpi=dpi)
    canvas = FigureCanvasAgg(fig)
    ax3 = fig.add_axes((0.0, 0.1, 0.56, 0.8), projection="3d")
    axf = fig.add_axes((0.56, 0.1, 0.44, 0.8), projection="3d")
    for ax in (ax3, axf):
        draw_scene(ax, scene, legend=False)
        ax.tick_params(labelsize=6 * scale)
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.label.set_size(7 * scale)
    ax3.view_init(elev=35, azim=-60)
    set_flat_view(axf, scene)
    fig.text(0.5, 0.965, title, ha="center", va="center", fontsize=10 * scale)
    bar = fig.add_axes((0.08, 0.035, 0.84, 0.025))
    bar.set_xlim(0.0, 1.0)
    bar.set_ylim(0.0, 1.0)
    bar.set_xticks([])
    bar.set_yticks([])
    fill = bar.axhspan(0.0, 1.0, xmin=0.0, xmax=0.0, color=PATH_COLOR, animated=True)
    fail_tick = bar.axvline(0.0, color=COLLISION_COLOR, lw=3 * scale, animated=True)
    fig.text(0.99, 0.075, f"links: red inside an obstacle, orange touching, green {CLEAR_MM:g} mm clear",
             ha="right", fontsize=7 * scale, color="0.3")
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)

    # moving artists: 2-D collections in each 3-D axes' projected coordinates, redrawn per frame
    moving = []
    for ax in (ax3, axf):
        links = LineCollection([], linewidths=max(4.0 * scale, 3.5), capstyle="round", animated=True)
        travelled = LineCollection([], linewidths=1.6 * scale, colors=[PATH_COLOR], animated=True)
        cross = Line2D([], [], marker="X", ms=14 * scale, color=COLLISION_COLOR, mec="black", mew=1.2, ls="",
                       animated=True)
        for artist in (links, travelled, cross):
            ax.add_artist(artist)
        moving.append((ax, links, travelled, cross))
    label = fig.text(0.01, 0.075, "", fontsize=8 * scale, animated=True)
    banner = fig.text(0.5, 0.915, "", ha="center", fontsize=11 * scale, color="white", fontweight="bold", animated=True,
                      bbox=dict(facecolor=COLLISION_COLOR, edgecolor="none", pad=3.0))

    path = frames.path
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    last = float(frames.depths[-1]) or 1.0
    hit = frames.collision_point
    step = _progress(len(frames.depths), "rendering") if progress else None
    for k, depth in enumerate(frames.depths):
        canvas.restore_region(background)
        body = frames.joints[k]
        colors = clearance_colors(frames.link_clearance[k])
        upto = np.vstack([path[cum < depth], _point_at(path, cum, depth)])
        failed = frames.failure_frame is not None and k >= frames.failure_frame
        for ax, links, travelled, cross in moving:
            proj = ax.get_proj()
            bx, by, _ = proj3d.proj_transform(*body.T, proj)
            links.set_segments(np.stack([np.column_stack([bx[:-1], by[:-1]]), np.column_stack([bx[1:], by[1:]])],
                                        axis=1))
            links.set_color(colors)
            px, py, _ = proj3d.proj_transform(*upto.T, proj)
            travelled.set_segments([np.column_stack([px, py])])
            ax.draw_artist(links)
            ax.draw_artist(travelled)
            if failed and hit is not None:
                hx, hy, _ = proj3d.proj_transform(*hit[:, None], proj)
                cross.set_data(hx, hy)
                ax.draw_artist(cross)
        fill.set_x(0.0)
        fill.set_width(depth / last)
        bar.draw_artist(fill)
        if failed:
            fail_tick.set_xdata([frames.failure.depth_mm / last] * 2)
            bar.draw_artist(fail_tick)
        clear = float(np.min(frames.link_clearance[k]))
        when = "" if frames.times is None else f"t = {frames.times[k]:6.2f} s   "
        label.set_text(f"{when}insertion {depth:7.1f} mm   min clearance {clear:6.1f} mm   frame {k + 1}/"
                       f"{len(frames.depths)}")
        fig.draw_artist(label)
        if failed:
            f = frames.failure
            banner.set_text(f"{f.kind.replace('_', ' ')} at {f.depth_mm:g} mm of insertion")
            fig.draw_artist(banner)
        if step is not None:
            step()
        yield np.asarray(canvas.buffer_rgba())[:, :, :3].copy()


def _point_at(path: np.ndarray, cum: np.ndarray, s: float) -> np.ndarray:
    """The point (mm) at arc length ``s`` along ``path``."""
    return np.array([np.interp(s, cum, path[:, k]) for k in range(3)])


def crawl_title(frames: CrawlFrames, planner: str = "", fps: float | None = None) -> str:
    """The video's title: scene, robot, planner, the judge's verdict, and how the frames are spaced: in time along
    the trajectory (with ``fps``, the speed-up at which the video plays it) or evenly in depth."""
    r = frames.report
    verdict = "feasible" if r.success else f"infeasible ({r.reason})"
    by = f", planned by {planner}" if planner else ""
    if frames.times is None:
        timed = ", evenly in depth"
    elif fps is None:
        timed = ", timed by TOPP-RA"
    else:
        motion, played = float(frames.times[-1]), len(frames.depths) / fps
        timed = f", timed by TOPP-RA: {motion:.1f} s of motion played in {played:.1f} s ({motion / played:.3g}x)"
    return f"{frames.scene.label}, {frames.robot.name}{by}: {verdict}{timed}"


def save_crawl_video(filename: str | Path, frames: CrawlFrames, fps: float = DEFAULT_FPS,
                     size: tuple[int, int] = DEFAULT_SIZE, planner: str = "", progress: bool = True) -> Path:
    """Render ``frames`` and write them to ``filename`` (.mp4 or .gif)."""
    rgb = crawl_frames_rgb(frames, crawl_title(frames, planner, fps), size, progress)
    return write_video(filename, rgb, len(frames.depths), fps, size)
