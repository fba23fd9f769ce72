"""A command's pictures of a crawl: the PNG (--plot, --out), the video (--animate) and the interactive page
(--html); each output is checked before any work is done."""

from __future__ import annotations

import argparse
import sys

from snakeplan.files import check_output

#: Insertion depths the interactive page's slider steps through.
HTML_FRAMES = 121


def check_picture(filename: str | None, field: str) -> None:
    """Refuse a picture path that could not be written, before any work is done."""
    if filename is not None:
        check_output(filename, field, (".png",))


def check_views(args: argparse.Namespace) -> None:
    """Refuse a video or page that could not be written, before any work is done."""
    if args.animate is not None:
        from snakeplan.viz.animation import check_video_options

        check_output(args.animate, "--animate", (".mp4", ".gif"))
        check_video_options(args.animate, args.frames, args.fps, args.frame_size, "--animate")
    if args.html is not None:
        check_output(args.html, "--html", (".html", ".htm"))


def write_plot(filename: str, scene, robot, path, report, planner: str = "") -> None:
    """The PNG of a scene with its judged path (if any) and the arm's body at its end."""
    from snakeplan.viz.figures import save_plan_figure

    save_plan_figure(filename, scene, robot, path, report, planner)


def write_views(args: argparse.Namespace, scene, robot, path, report, planner: str = "") -> None:
    """Write the video and the page a command was asked for (each says on stderr what it wrote, or why not)."""
    if args.animate is None and args.html is None:
        return
    if path is None:
        sys.stderr.write("snakeplan: no video or page: there is no path to show\n")
        return
    from snakeplan.viz.crawl import crawl_frames

    if args.animate is not None:
        from snakeplan.viz.animation import save_crawl_video

        frames = crawl_frames(scene, robot, path, args.frames, report)
        save_crawl_video(args.animate, frames, args.fps, args.frame_size, planner, progress=sys.stderr.isatty())
        sys.stderr.write(f"wrote {args.animate} ({len(frames.depths)} frames at {args.fps:g} fps)\n")
    if args.html is not None:
        from snakeplan.viz.page import save_crawl_page

        save_crawl_page(args.html, crawl_frames(scene, robot, path, HTML_FRAMES, report), planner)
        sys.stderr.write(f"wrote {args.html}\n")


def write_episode_views(args: argparse.Namespace, episode, plot: str | None) -> None:
    """Write the picture, video and page a planning command was asked for, whatever the episode's task (each named
    on stderr, or why not)."""
    if not plot and args.animate is None and args.html is None:
        return
    from snakeplan.viz import episode as views

    if plot:
        views.save_episode_plot(plot, episode)
        sys.stderr.write(f"wrote {plot}\n")
    if args.animate is None and args.html is None:
        return
    if episode.plan.path is None:
        sys.stderr.write("snakeplan: no video or page: there is no path to show\n")
        return
    if args.animate is not None:
        frames = views.save_episode_video(args.animate, episode, args.frames, args.fps, args.frame_size,
                                          sys.stderr.isatty())
        sys.stderr.write(f"wrote {args.animate} ({frames} frames at {args.fps:g} fps)\n")
    if args.html is not None:
        views.save_episode_page(args.html, episode, HTML_FRAMES)
        sys.stderr.write(f"wrote {args.html}\n")
