"""One camera's per-frame results as MCAP messages, for the daemon and ``weatherd replay``."""

from __future__ import annotations

import cv2
import numpy as np

from daemon.config import RecordingConfig
from daemon.transport.messages import frame_message, histogram_message, schema_for
from hos.overlay import draw_overlay
from hos.params import DetectorParams
from hos.result import FrameResult

from .recorder import FOXGLOVE_COMPRESSED_IMAGE_SCHEMA, Recorder, compressed_image

__all__ = ["ResultRecorder", "thumbnail_jpeg"]


class ResultRecorder:
    """Writes one camera's per-frame results to the recorder: ``/hos/<cam>/frame``,
    ``/hos/<cam>/histogram`` and, every ``thumbnail_interval_s``, an overlay thumbnail on
    ``/hos/<cam>/thumbnail``. Shared by the daemon and ``weatherd replay``."""

    def __init__(
        self,
        recorder: Recorder,
        *,
        site: str,
        camera: str,
        params: DetectorParams,
        config: RecordingConfig,
    ):
        self.recorder = recorder
        self.site = site
        self.camera = camera
        self.params = params
        self.config = config
        self._next_thumb_ns: int | None = None
        self._frame_schema = schema_for("hos.frame")
        self._hist_schema = schema_for("hos.histogram")

    def write(self, result: FrameResult, gray: np.ndarray, *, t_ns: int) -> None:
        cam, site = self.camera, self.site
        if self.config.per_frame:
            self.recorder.write(
                f"/hos/{cam}/frame",
                "hos.frame",
                self._frame_schema,
                frame_message(result, site=site, camera=cam, t_ns=t_ns),
                t_ns=t_ns,
            )
            self.recorder.write(
                f"/hos/{cam}/histogram",
                "hos.histogram",
                self._hist_schema,
                histogram_message(result, site=site, camera=cam, t_ns=t_ns),
                t_ns=t_ns,
            )
        interval = self.config.thumbnail_interval_s
        if interval > 0 and (self._next_thumb_ns is None or t_ns >= self._next_thumb_ns):
            self._next_thumb_ns = t_ns + int(interval * 1e9)
            jpeg = thumbnail_jpeg(gray, result, self.params, width=self.config.thumbnail_width)
            self.recorder.write(
                f"/hos/{cam}/thumbnail",
                "foxglove.CompressedImage",
                FOXGLOVE_COMPRESSED_IMAGE_SCHEMA,
                compressed_image(jpeg, t_ns=t_ns, frame_id=cam),
                t_ns=t_ns,
            )


def thumbnail_jpeg(
    gray: np.ndarray, result: FrameResult, params: DetectorParams, *, width: int
) -> bytes:
    """The overlay of ``result`` on ``gray``, scaled to ``width`` pixels, as JPEG bytes."""
    image = draw_overlay(gray, result, params=params)
    h, w = image.shape[:2]
    if w > width:
        image = cv2.resize(
            image, (width, max(1, round(h * width / w))), interpolation=cv2.INTER_AREA
        )
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 80])
    if not ok:  # pragma: no cover - OpenCV encodes any BGR uint8 image
        raise RuntimeError("JPEG encoding failed")
    return buf.tobytes()
