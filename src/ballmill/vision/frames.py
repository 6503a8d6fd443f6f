"""Reading and writing frame sequences: a lossless video file or a folder of images.

Containers often cannot hold a capture rate like 2134 fps, so videos are written at a
nominal playback rate and the capture rate travels in a JSON sidecar (`<video>.json`), as
high-speed cameras' files do; it can always be given explicitly instead.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from pathlib import Path

import cv2
import numpy as np

from ..config import ConfigError

IMAGE_SUFFIXES = {".png", ".tif", ".tiff", ".bmp", ".jpg", ".jpeg"}
# Lossless codecs by container: .avi uncompressed 8-bit grey (Y800, as a high-speed camera's raw
# file; a 360 x 108 frame of sensor noise writes in 0.03 ms and reads in 0.11 ms, 39 kB), .mkv
# FFV1 (0.55 and 0.76 ms, 17 kB: the noise leaves little to compress).
VIDEO_CODECS = {".avi": "Y800", ".mkv": "FFV1"}


def write_frames(frames: Iterable[np.ndarray], path: str | Path, capture_fps: float, mm_per_px: float,
                 playback_fps: float = 30.0) -> Path:
    """Greyscale uint8 frames to a lossless video (.avi: uncompressed, .mkv: FFV1) or to PNGs in a folder."""
    path = Path(path)
    meta = {"capture_fps": capture_fps, "mm_per_px": mm_per_px, "playback_fps": playback_fps}
    writer = None
    codec = VIDEO_CODECS.get(path.suffix.lower())
    if codec:
        path.parent.mkdir(parents=True, exist_ok=True)
        for frame in frames:
            if writer is None:
                h, w = frame.shape
                writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*codec), playback_fps, (w, h), isColor=False)
                if not writer.isOpened():
                    raise RuntimeError(f"OpenCV cannot write a {codec} video to {path}; write PNG frames to a folder")
            writer.write(frame)
        if writer is not None:
            writer.release()
        path.with_suffix(path.suffix + ".json").write_text(json.dumps(meta))
    else:
        path.mkdir(parents=True, exist_ok=True)
        for k, frame in enumerate(frames):
            cv2.imwrite(str(path / f"frame_{k:06d}.png"), frame)
        (path / "capture.json").write_text(json.dumps(meta))
    return path


def read_meta(path: str | Path) -> dict:
    """Capture metadata written beside a video or inside a frame folder ({} when none)."""
    path = Path(path)
    side = path / "capture.json" if path.is_dir() else path.with_suffix(path.suffix + ".json")
    if not side.exists():
        return {}
    try:
        meta = json.loads(side.read_text())
    except ValueError as exc:
        raise ConfigError(f"{side}: not valid JSON ({exc}); fix or delete it and give fps= and mm_per_px=") from exc
    for key in ("capture_fps", "mm_per_px"):
        if key in meta and not (isinstance(meta[key], (int, float)) and meta[key] > 0):
            raise ConfigError(f"{side}: {key}={meta[key]!r} must be a positive number")
    return meta


def _image_files(folder: Path) -> list[Path]:
    """The folder's images, sorted by name (an error when there are none)."""
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise FileNotFoundError(f"video={folder}: no image files ({sorted(IMAGE_SUFFIXES)}) in the folder")
    return files


def _read_image(folder: Path, file: Path) -> np.ndarray:
    frame = cv2.imread(str(file), cv2.IMREAD_GRAYSCALE)
    if frame is None:
        raise ConfigError(f"video={folder}: {file.name} is not a readable image")
    return frame


def _grey(frame: np.ndarray) -> np.ndarray:
    return frame if frame.ndim == 2 else cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)


def read_frames(path: str | Path) -> Iterator[np.ndarray]:
    """Greyscale frames of a video file or of the images in a folder (sorted by name)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"video={path} does not exist")
    if path.is_dir():
        for f in _image_files(path):
            yield _read_image(path, f)
        return
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise ConfigError(f"video={path}: OpenCV cannot open it (not a video, empty or truncated); give a video "
                          f"file or a folder of images ({sorted(IMAGE_SUFFIXES)})")
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        yield _grey(frame)
    cap.release()


def spread_frames(path: str | Path, n: int) -> list[np.ndarray]:
    """About n greyscale frames evenly spaced through a video or folder (between n and 2n when the
    video does not tell its length); a video is sought, not decoded, between them."""
    path = Path(path)

    def spread(count: int):
        return np.unique(np.linspace(0, count - 1, n).round().astype(int)) if count > 0 else ()

    if path.is_dir():
        files = _image_files(path)
        return [_read_image(path, files[k]) for k in spread(len(files))]
    cap = cv2.VideoCapture(str(path))
    keep = []
    for k in spread(int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) if cap.isOpened() else 0):
        cap.set(cv2.CAP_PROP_POS_FRAMES, int(k))
        ok, frame = cap.read()
        if ok:
            keep.append(_grey(frame))
    cap.release()
    if keep:
        return keep
    stride = 1  # a stream of unknown length: keep every stride-th frame, halving when 2n are held
    for k, frame in enumerate(read_frames(path)):
        if k % stride == 0:
            keep.append(frame)
            if len(keep) == 2 * n:
                keep, stride = keep[::2], stride * 2
    return keep
