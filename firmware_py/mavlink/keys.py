"""MAVLink 2 signing keys from files."""
from __future__ import annotations

import base64
import binascii
from pathlib import Path

__all__ = ["load_signing_key"]


def load_signing_key(path: str | Path) -> bytes:
    """A 32-byte MAVLink 2 signing key from a file: 32 raw bytes, 64 hex digits, or base64 of 32 bytes.

    Surrounding whitespace is ignored in the text forms.

    Parameters
    ----------
    path : str or Path
        The key file.

    Raises
    ------
    ValueError
        Saying what was found, when the file holds none of the three forms.
    OSError
        When the file cannot be read.
    """
    path = Path(path)
    data = path.read_bytes()
    if len(data) == 32:
        return data
    text = data.strip()
    if len(text) == 64:
        try:
            return bytes.fromhex(text.decode("ascii"))
        except (UnicodeDecodeError, ValueError):
            pass
    try:
        key = base64.b64decode(text, validate=True)
        if len(key) == 32:
            return key
    except (binascii.Error, ValueError):
        pass
    raise ValueError(f"{path}: not a MAVLink 2 signing key: expected 32 raw bytes, 64 hex digits or base64 of "
                     f"32 bytes; the file holds {len(data)} bytes")
