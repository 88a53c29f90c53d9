"""Progress bars of the offline commands: on a terminal only, with a total (and so an ETA)
whenever the total is known.

``detect``, ``replay``, ``simulate`` count frames (the total is the video reader's
``frame_count`` when it has one); ``calibrate`` and ``compare`` count the frame messages of the
logs, whose number the MCAP summaries give before any message is read, so that one long log
shows its progress too. A pipe, a file or a journal gets no bar at all: tqdm's carriage returns
would fill it.
"""

from __future__ import annotations

import sys
from typing import Any

__all__ = ["progress_bar"]


def progress_bar(
    total: int | None, *, desc: str, unit: str = "frame", enabled: bool | None = None
) -> Any:
    """A tqdm bar on stderr, or None.

    Parameters
    ----------
    total : number of units expected; None or 0: unknown (the bar then counts without an ETA)
    desc : what is being read, shown first
    unit : what one step of ``update(1)`` is
    enabled : False: no bar; True or None: a bar when stderr is a terminal
    """
    if enabled is False or not sys.stderr.isatty():
        return None
    from tqdm import tqdm

    return tqdm(
        total=total or None,
        desc=desc,
        unit=unit,
        leave=False,
        dynamic_ncols=True,
        mininterval=0.5,
    )
