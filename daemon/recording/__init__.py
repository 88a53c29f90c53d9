"""What stays on the box: MCAP recordings, written so that a crash or a full disk loses little.

``recorder``         :class:`~.recorder.Recorder`: rotation, disk budget, flush and fsync timers
``results``          one camera's per-frame results, histograms and thumbnails as messages
``mcap_json``        the JSON messages and the Foxglove schemas
``mcap_file``        one MCAP file being written; the format's facts
``recording_files``  naming, listing and free space of the recording directory
``mcap_repair``      repair of unfinished files (``weatherd recover``, and at start-up)
"""
