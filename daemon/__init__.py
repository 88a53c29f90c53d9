"""The long-running service, its transport and recording, the offline tools and the command line.

One sub-package a job; each depends only on those listed before it:

``config``     the validated configuration (pydantic), shared by all of them
``transport``  Zenoh: message payloads and their JSON Schemas, the publisher, watch/get clients
``recording``  MCAP: the recorder (rotation, budget, crash safety), repair, per-frame results
``service``    ``weatherd run``: capture, detection, fusion, calibration, instruments, systemd
``offline``    replay, station reference data, calibration of R, comparison, reports
``cli``        the ``weatherd`` command: one module per subcommand

The sub-packages' ``__init__`` modules import nothing: importing a light module (the message
builders, say) must not pull in Zenoh, the recorder or the detector's kernels.
"""
