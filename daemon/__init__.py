"""The long-running service and the ``weatherd`` command line (``daemon.cli``)."""
