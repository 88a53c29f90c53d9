"""Validation of messages against the JSON Schemas in docs/schemas (daemon/transport/schemas)."""

from __future__ import annotations

from typing import Any

import jsonschema

from daemon.transport.messages import schema_for

_FORMATS = jsonschema.Draft202012Validator.FORMAT_CHECKER


def validate(message: dict[str, Any]) -> None:
    """Raise ``jsonschema.ValidationError`` unless ``message`` matches the schema it names."""
    kind, _, version = message["schema"].partition("/")
    assert version == "1", message["schema"]
    jsonschema.Draft202012Validator(schema_for(kind), format_checker=_FORMATS).validate(message)
