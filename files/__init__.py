"""Files the user keeps: written atomically (a reader sees the old file or the whole new one)
and readable by others as the user's umask allows (0644 files, 0755 folders under umask 022),
whatever the temporary file was created with.

The bottom of the stack: it imports nothing of ours, so every stage can use it. The one
exception is ``scenario_lib/builder.py``, which also runs inside the sandbox where only the
``scenario_lib`` folder is mounted; it sets the same mode with :func:`file_mode`'s rule spelled out.
"""

from scenweave.files.atomic import (
    file_mode,
    write_bytes_atomic,
    write_json_atomic,
    write_text_atomic,
)

__all__ = ["file_mode", "write_bytes_atomic", "write_json_atomic", "write_text_atomic"]
