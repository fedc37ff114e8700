"""Where the queue is and how its Redis keys are named: the URL (``--queue``,
``$SCENWEAVE_QUEUE``), a checked connection, the job id of a scenario and the keys of a run's
hand-back. Every other module of the queue builds on these names.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar
from urllib.parse import urlsplit, urlunsplit

from scenweave.errors import InfrastructureError
from scenweave.run_folder import safe_name

QUEUE_NAME = "scenweave"

QUEUE_ENV = "SCENWEAVE_QUEUE"


DEFAULT_QUEUE_URL = "redis://127.0.0.1:6379/0"

#: how long a worker, ``submit --wait`` or ``collect --wait`` waits for Redis to come back
OUTAGE_ENV = "SCENWEAVE_QUEUE_OUTAGE_S"
DEFAULT_OUTAGE_S = 300.0
#: the first and the longest pause between two knocks at a Redis that does not answer
FIRST_KNOCK_S, LONGEST_KNOCK_S = 0.2, 5.0

T = TypeVar("T")


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


def connect(url: str | None = None, wait: bool = False) -> Any:
    """A checked connection to the Redis of ``url`` (``redis://`` or TLS ``rediss://``, a
    password as ``redis://:PASSWORD@host``); QueueError names the setting to change. With
    ``wait`` (a worker, which may well start before its Redis) a Redis that does not answer
    is waited for as an outage is (``wait_for_queue``: bounded, said once)."""
    from redis import Redis
    from redis.exceptions import ConnectionError as RedisConnectionError
    from redis.exceptions import RedisError
    from redis.exceptions import TimeoutError as RedisTimeoutError

    url = queue_url(url)
    try:
        connection = Redis.from_url(url)
        connection.ping()
    except (RedisConnectionError, RedisTimeoutError) as err:
        if not wait or not _may_come_back(err):
            raise _unreachable(url, err) from err
        wait_for_queue(connection, err)
    except (RedisError, ValueError) as err:
        raise _unreachable(url, err) from err
    return connection


def _unreachable(url: str, err: Exception) -> QueueError:
    """The one line saying why the queue at ``url`` cannot be used and what to change."""
    if _is_refused_login(err):
        return QueueError(f"the job queue at {redacted(url)} refused the login ({err}): it "
                          "needs its password in the URL, redis://:PASSWORD@host:6379/0 "
                          f"(--queue / {QUEUE_ENV})")
    return QueueError(f"cannot reach the job queue at {redacted(url)}: {err}; start "
                      f"redis-server there or pass --queue / set {QUEUE_ENV} (a password "
                      "goes in the URL: redis://:PASSWORD@host:6379/0)")


def _may_come_back(err: Exception) -> bool:
    """Whether waiting can help: a Redis not up (yet), not one refusing the login or the
    certificate (waiting would not change either)."""
    import ssl

    return not _is_refused_login(err) and not isinstance(err.__context__, ssl.SSLError)


def _is_refused_login(err: Exception) -> bool:
    from redis.exceptions import AuthenticationError

    text = str(err)
    return isinstance(err, AuthenticationError) or "NOAUTH" in text or "authenticated" in text


def job_id(run_id: str, scenario_id: str) -> str:
    """The RQ job id of a scenario of a run (RQ allows letters, digits, ``_`` and ``-``)."""
    return safe_name(f"{run_id}--{scenario_id}").replace(".", "_")


def outage_budget_s() -> float:
    """How long to wait for an unreachable Redis: ``$SCENWEAVE_QUEUE_OUTAGE_S`` or 5 min."""
    return float(os.environ.get(OUTAGE_ENV) or DEFAULT_OUTAGE_S)


def _say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def wait_for_queue(connection: Any, err: Exception, budget_s: float | None = None,
                   say: Callable[[str], None] = _say) -> float:
    """Knock at Redis (backing off up to ``LONGEST_KNOCK_S``) until it answers again, saying
    once that it is waited for and once that it is back; return the seconds waited.

    A restarted Redis keeps what its append-only file kept (``--appendonly yes``): without
    it the queue comes back empty, and the callers find their jobs gone and say so.
    QueueError once ``budget_s`` (``outage_budget_s``) passed without an answer."""
    from redis.exceptions import RedisError

    budget_s = outage_budget_s() if budget_s is None else budget_s
    where = _where(connection)
    say(f"the job queue at {where} does not answer ({err}); waiting up to {budget_s:.0f} s "
        f"for it to come back ({OUTAGE_ENV})")
    start = time.monotonic()
    pause = FIRST_KNOCK_S
    while True:
        time.sleep(pause)
        try:
            connection.ping()
        except RedisError as again:
            waited = time.monotonic() - start
            if waited >= budget_s:
                raise QueueError(f"the job queue at {where} did not come back within "
                                 f"{budget_s:.0f} s ({again}); start redis-server there, then "
                                 "run the same command again") from again
            pause = min(pause * 2, LONGEST_KNOCK_S, max(budget_s - waited, 0.05))
            continue
        waited = time.monotonic() - start
        say(f"the job queue at {where} is back after {waited:.1f} s; carrying on")
        return waited


def riding_out(call: Callable[[], T], connection: Any, budget_s: float | None = None,
               say: Callable[[str], None] = _say) -> T:
    """``call()``, called again each time Redis comes back from an outage (a refused or cut
    connection, a time-out, a Redis still loading its data): for idempotent steps only."""
    from redis.exceptions import ConnectionError as RedisConnectionError
    from redis.exceptions import TimeoutError as RedisTimeoutError

    budget_s = outage_budget_s() if budget_s is None else budget_s
    deadline = time.monotonic() + budget_s
    while True:
        try:
            return call()
        except (RedisConnectionError, RedisTimeoutError) as err:
            wait_for_queue(connection, err, max(deadline - time.monotonic(), 0.0), say)


def _where(connection: Any) -> str:
    kwargs = connection.connection_pool.connection_kwargs
    return f"{kwargs.get('host', '?')}:{kwargs.get('port', '?')}"
