"""``weatherd run``: the service's threads and their logic.

``app``          the daemon: start-up, the main loop, shutdown; one camera's pipeline
``capture``      the capture thread: newest-frame slot, reconnection with backoff
``detection``    the detector pipelined over two threads (segmentation beside analysis)
``fusion``       camera summaries and instruments into the site's weather state
``calibration``  the online calibration of R into mm/h
``instruments``  the serial instruments' readers, accumulations and views
``sdnotify``     systemd's notify protocol: READY, WATCHDOG, STOPPING
"""
