"""The status page: a small web page and read-only JSON API served by ``weatherd run``
(docs/daemon.md, "Status page")."""

from .auth import Secrets, load_secrets
from .hub import CameraFeed, FeedFrame, WebHub, blob_centroids
from .server import WebServer

__all__ = [
    "CameraFeed",
    "FeedFrame",
    "Secrets",
    "WebHub",
    "WebServer",
    "blob_centroids",
    "load_secrets",
]
