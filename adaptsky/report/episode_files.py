"""The pictures of episodes as files (docs/pictures.md): the figure as PNG, PDF or SVG, as the
suffix of its name says, and the animation as GIF (through Pillow, which matplotlib brings) or
MP4 (through ffmpeg from imageio-ffmpeg, the optional extra ``adaptsky[video]``). Each file
is written whole or not at all; a name's format, and the MP4 writer, are checked before any
work (:func:`figure_format`, :func:`animation_format`)."""

from __future__ import annotations

import io
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from adaptsky.drawing.episode import EpisodeData, default_every, frame_steps
from adaptsky.drawing.episode_figure import DPI, EpisodeFigure
from adaptsky.errors import AdaptskyError
from adaptsky.progress import Reporter, Silent, Tick, WorkProgress
from adaptsky.report.figure_files import format_of
from adaptsky.store.atomic import write_bytes_atomic, written_in_place_of

ANIMATION_FORMATS = ("gif", "mp4")
FPS = 20
"""Frames per second of an animation, by default."""
VIDEO_EXTRA = "pip install 'adaptsky[video]'"
"""How to install what MP4 needs (imageio-ffmpeg, with its own ffmpeg)."""
GIF_COLOURS = 255


def figure_format(path: Path) -> str:
    """png, pdf or svg, from ``path``'s suffix (any case); anything else in one line
    (:func:`adaptsky.report.figure_files.format_of`, as every figure of adaptsky)."""
    return format_of(path, "--out")


def animation_format(path: Path) -> str:
    """gif or mp4, from ``path``'s suffix; anything else, or MP4 without imageio-ffmpeg, in
    one line."""
    fmt = format_of(path, "--animate", "an animation file", ANIMATION_FORMATS)
    if fmt == "mp4":
        require_video(path)
    return fmt


def require_video(path: Path) -> None:
    """Refuse, in one line, an MP4 where imageio-ffmpeg (or its ffmpeg) is missing."""
    try:
        import imageio_ffmpeg

        imageio_ffmpeg.get_ffmpeg_exe()
    except ImportError:
        raise AdaptskyError(f"--animate {path}: an MP4 needs imageio-ffmpeg, which is not "
                            f"installed; install it with {VIDEO_EXTRA}, or write a .gif"
                            ) from None
    except RuntimeError as error:  # installed without a usable ffmpeg
        raise AdaptskyError(f"--animate {path}: an MP4 needs ffmpeg, which imageio-ffmpeg "
                            f"cannot find ({str(error).splitlines()[0]}); reinstall it with "
                            f"{VIDEO_EXTRA}, or write a .gif") from None


def write_figure(path: Path, episodes: Sequence[EpisodeData], *, side_m: float,
                 dpi: float = DPI) -> None:
    """The picture of ``episodes`` (every step) at ``path``, in the format of its suffix."""
    fmt = figure_format(path)
    figure = EpisodeFigure(episodes, side_m=side_m, dpi=dpi)
    write_bytes_atomic(path, figure.save(fmt))


def write_animation(path: Path, episodes: Sequence[EpisodeData], *, side_m: float,
                    dpi: float = DPI, every: int | None = None, fps: float = FPS,
                    progress: Reporter | None = None) -> int:
    """``episodes`` as an animation at ``path`` (GIF or MP4, by its suffix), a frame every
    ``every`` steps (default: at most about 200 frames) and the last, ``fps`` frames per
    second; ``progress`` hears the frames done. Returns the number of frames."""
    fmt = animation_format(path)
    figure = EpisodeFigure(episodes, side_m=side_m, dpi=dpi)
    steps = max(episode.steps for episode in episodes)
    rows = frame_steps(steps, every or default_every(steps))
    with WorkProgress(progress or Silent()) as work, \
            work.stage("frames", len(rows), "frame") as tick:
        if fmt == "gif":
            _write_gif(path, figure, rows, fps, tick)
        else:
            _write_mp4(path, figure, rows, fps, tick)
    return len(rows)


def _frames(figure: EpisodeFigure, rows: list[int], tick: Tick) -> Iterator[memoryview]:
    """Every frame, RGBA (a view of the canvas, valid until the next)."""
    for done, row in enumerate(rows, start=1):
        figure.show(row)
        yield figure.rgba()
        tick(done)


def _write_gif(path: Path, figure: EpisodeFigure, rows: list[int], fps: float,
               tick: Tick) -> None:
    """Every frame in the palette of the whole picture (every colour a frame can have),
    without dithering: the frames differ where the picture changes, and compress."""
    from PIL import Image

    size = figure.size_px
    figure.show()
    palette = Image.fromarray(figure.rgb()).quantize(GIF_COLOURS,
                                                     method=Image.Quantize.MEDIANCUT)
    frames = [Image.frombuffer("RGBA", size, rgba, "raw", "RGBA", 0, 1).convert("RGB")
              .quantize(palette=palette, dither=Image.Dither.NONE)
              for rgba in _frames(figure, rows, tick)]
    buffer = io.BytesIO()
    frames[0].save(buffer, format="GIF", save_all=True, append_images=frames[1:],
                   duration=round(1000 / fps), loop=0)
    write_bytes_atomic(path, buffer.getvalue())


def _write_mp4(path: Path, figure: EpisodeFigure, rows: list[int], fps: float,
               tick: Tick) -> None:
    """H.264 in yuv420p (which every player shows); a frame of odd width or height gets a
    white row or column more, as the format needs even sizes."""
    import imageio_ffmpeg

    width, height = figure.size_px
    padding = ((0, height % 2), (0, width % 2), (0, 0))
    with written_in_place_of(path) as tmp:
        writer = imageio_ffmpeg.write_frames(
            str(tmp), (width + width % 2, height + height % 2), fps=fps, codec="libx264",
            pix_fmt_in="rgb24", macro_block_size=1, ffmpeg_log_level="error")
        writer.send(None)
        try:
            for rgba in _frames(figure, rows, tick):
                rgb = np.asarray(rgba)[:, :, :3]
                writer.send(np.ascontiguousarray(np.pad(rgb, padding, constant_values=255)))
        finally:
            writer.close()
