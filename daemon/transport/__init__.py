"""What leaves the box over Zenoh (key space and payloads are a contract: ``docs/daemon.md``).

``messages``  the JSON payloads and their schemas (``schemas/*.schema.json``)
``publisher`` the Zenoh session: puts, the liveliness token, the queryable, reconnection
``watch``     the ``weatherd watch`` and ``get`` clients
"""
