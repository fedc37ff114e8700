"""Where the queue is and how its Redis keys are named: the URL (``--queue``,
``$SCENWEAVE_QUEUE``), a checked connection, the job id of a scenario and the keys of a run's
hand-back. Every other module of the queue builds on these names.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlsplit, urlunsplit

from scenweave.errors import InfrastructureError
from scenweave.run_folder import safe_name

QUEUE_NAME = "scenweave"

QUEUE_ENV = "SCENWEAVE_QUEUE"


DEFAULT_QUEUE_URL = "redis://127.0.0.1:6379/0"


class QueueError(InfrastructureError):
    """Root of the queue's infrastructure failures (Redis unreachable, ...)."""


@dataclass(frozen=True)
class RunKeys:
    """The Redis keys of one run's hand-back: parcels not collected yet, what was made (by
    which submission) and the scenarios the submitter still waits for."""

    run_id: str

    @property
    def parcels(self) -> str:
        return f"scenweave:run:{self.run_id}:parcels"

    @property
    def made(self) -> str:
        return f"scenweave:run:{self.run_id}:made"

    @property
    def pending(self) -> str:
        return f"scenweave:run:{self.run_id}:pending"


def map_key(sha256: str) -> str:
    """The Redis key holding a map file's compressed content."""
    return f"scenweave:map:{sha256}"


def queue_url(url: str | None = None) -> str:
    """The Redis URL to use: ``url``, else ``$SCENWEAVE_QUEUE``, else the local default."""
    return url or os.environ.get(QUEUE_ENV) or DEFAULT_QUEUE_URL


def redacted(url: str) -> str:
    """``url`` with its password replaced by ``***``, for messages and ``run.json``."""
    parts = urlsplit(url)
    if not parts.password:
        return url
    user = parts.username or ""
    host = parts.hostname or ""
    netloc = f"{user}:***@{host}" + (f":{parts.port}" if parts.port else "")
    return urlunsplit(parts._replace(netloc=netloc))


def connect(url: str | None = None) -> Any:
    """A checked connection to the Redis of ``url`` (``redis://`` or TLS ``rediss://``, a
    password as ``redis://:PASSWORD@host``); QueueError names the setting to change."""
    from redis import Redis
    from redis.exceptions import RedisError

    url = queue_url(url)
    try:
        connection = Redis.from_url(url)
        connection.ping()
    except (RedisError, ValueError) as err:
        if _is_refused_login(err):
            raise QueueError(f"the job queue at {redacted(url)} refused the login ({err}): it "
                             "needs its password in the URL, redis://:PASSWORD@host:6379/0 "
                             f"(--queue / {QUEUE_ENV})") from err
        raise QueueError(f"cannot reach the job queue at {redacted(url)}: {err}; start "
                         f"redis-server there or pass --queue / set {QUEUE_ENV} (a password "
                         "goes in the URL: redis://:PASSWORD@host:6379/0)") from err
    return connection


def _is_refused_login(err: Exception) -> bool:
    from redis.exceptions import AuthenticationError

    text = str(err)
    return isinstance(err, AuthenticationError) or "NOAUTH" in text or "authenticated" in text


def job_id(run_id: str, scenario_id: str) -> str:
    """The RQ job id of a scenario of a run (RQ allows letters, digits, ``_`` and ``-``)."""
    return safe_name(f"{run_id}--{scenario_id}").replace(".", "_")
