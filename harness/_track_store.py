"""The results store of ``harness track``: every sample of every commit measured, kept across commits.

A Parquet dataset partitioned by machine and commit, Hive style, in a local folder by default or at any
fsspec URL (``s3://bucket/track``, ``gcs://...``, ``memory://`` in tests) for a store shared by machines::

    STORE/machine=<id>/commit=<40 hex>/<session>.parquet

``<id>`` is 12 hex digits of the SHA-256 of the machine's host name, processor model and core count
(`machine_id`): times are only ever compared within one machine. Each part file holds one session: a
commit measured side by side with the history's anchor commit (`reports._tracking`), the samples of both
(`harness._bench_session.SAMPLE_COLUMNS`, ``version`` telling the two apart and ``commit`` the partition's,
plus the columns of `SESSION_COLUMNS`), and its Parquet metadata holds the session's problems (answers the
check rejected, what could not be measured) as JSON under ``harness.problems``. Files are only ever added,
under new names (`registry.write_new`), never replaced or removed: a store written by two machines at once,
or by an interrupted run, holds every whole file and nothing half-written.
"""

from __future__ import annotations

import hashlib
import io
import json
import uuid
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from harness._bench_session import SAMPLE_COLUMNS, Measurement
from harness._commits import CommitFacts
from registry import HarnessError, write_new

#: Columns a store adds to a session's samples: the suite, the session (one ``track`` measurement of one
#: commit), the anchor commit it was measured beside, when it was measured, the commit's own date and
#: subject, and the machine described in words.
SESSION_COLUMNS = ("suite", "session", "anchor", "measured", "commit_date", "subject", "machine_name")

#: Where a part file keeps its session's problems.
PROBLEMS_KEY = b"harness.problems"


class StoreError(HarnessError):
    """A store that cannot be opened, read or written."""


def machine_id(machine: dict[str, Any]) -> str:
    """12 hex digits naming a machine: host name, processor model and core count (`harness._environment
    .machine`)."""
    text = "|".join(str(machine.get(key)) for key in ("hostname", "cpu_model", "cpu_count"))
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def machine_name(machine: dict[str, Any]) -> str:
    """``host, 2 CPUs, model`` for tables and the dashboard."""
    return f"{machine.get('hostname')}, {machine.get('cpu_count')} CPUs, {machine.get('cpu_model') or '?'}"


class TrackStore:
    """A results store at a local path or fsspec URL (module notes).

    Raises
    ------
    StoreError
        When the URL's file system is unknown or cannot be reached.
    """

    def __init__(self, url: str) -> None:
        import fsspec

        try:
            self.filesystem, self.root = fsspec.core.url_to_fs(url)
            is_file = self.filesystem.isfile(self.root)
        except (ValueError, ImportError, OSError) as error:
            raise StoreError(f"track store {url!r}: {error}") from None
        if is_file:
            raise StoreError(f"track store {url!r}: is a file, not the folder of a store")
        self.url = url

    def add(self, measurement: Measurement, facts: CommitFacts, anchor: str, machine: dict[str, Any]) -> str:
        """Write the samples of a commit measured beside ``anchor`` as a new part file; returns its path.

        Raises
        ------
        StoreError
            When the measurement is not of the commit and the anchor, or the store cannot be written.
        """
        if {version.commit for version in measurement.versions} - {facts.commit, anchor}:
            raise StoreError("a store part holds a commit's samples and its anchor's")
        session = uuid.uuid4().hex[:16]
        frame = measurement.samples.drop(columns=["commit"]).assign(
            suite=measurement.suite.name,
            session=session,
            anchor=anchor,
            measured=measurement.started,
            commit_date=facts.date,
            subject=facts.subject,
            machine_name=machine_name(machine),
        )
        table = pa.Table.from_pandas(frame, preserve_index=False)
        problems = json.dumps(measurement.errors + _rejected(measurement)).encode()
        table = table.replace_schema_metadata({**(table.schema.metadata or {}), PROBLEMS_KEY: problems})
        buffer = io.BytesIO()
        pq.write_table(table, buffer)
        path = f"{self.root}/machine={machine_id(machine)}/commit={facts.commit}/{session}.parquet"
        try:
            write_new(self.filesystem, path, buffer.getvalue())
        except OSError as error:
            raise StoreError(f"track store {self.url}: cannot write {path}: {error}") from None
        return path

    def parts(self) -> list[str]:
        """Every part file of the store (none for a store not made yet)."""
        try:
            found = self.filesystem.glob(f"{self.root}/machine=*/commit=*/*.parquet")
        except (OSError, ValueError) as error:
            raise StoreError(f"track store {self.url}: {error}") from None
        return sorted(str(path) for path in found if not str(path).rsplit("/", 1)[-1].startswith("."))

    def read(
        self, *, machine: str | None = None, suite: str | None = None, anchor: str | None = None
    ) -> pd.DataFrame:
        """Every sample of the store, of one machine, suite and anchor when given.

        Returns
        -------
        DataFrame with `SAMPLE_COLUMNS`, `SESSION_COLUMNS`, ``machine`` (the id) and ``problems`` (the
        session's problems joined by newlines).

        Raises
        ------
        StoreError
            For a part file that does not read (named).
        """
        frames = []
        for path in self.parts():
            where = dict(part.split("=", 1) for part in path.split("/") if "=" in part)
            if machine is not None and where.get("machine") != machine:
                continue
            try:
                with self.filesystem.open(path, "rb") as stream:
                    table = pq.read_table(stream)
                problems = json.loads((table.schema.metadata or {}).get(PROBLEMS_KEY, b"[]"))
            except (OSError, ValueError, pa.ArrowException) as error:
                raise StoreError(f"track store: {path} does not read ({error})") from None
            expected = {*SAMPLE_COLUMNS, *SESSION_COLUMNS} - {"machine", "commit"}
            missing = sorted(expected - set(table.column_names))
            if missing or not isinstance(problems, list):
                what = f"it lacks {', '.join(missing)}" if missing else "its problems are not a list"
                raise StoreError(f"track store: {path} is not a part of a store ({what})")
            frame = table.to_pandas().assign(
                machine=where.get("machine", ""), commit=where.get("commit", ""), problems="\n".join(problems)
            )
            if (suite is None or (frame["suite"] == suite).all()) and (
                anchor is None or (frame["anchor"] == anchor).all()
            ):
                frames.append(frame)
        columns = [*SAMPLE_COLUMNS, *SESSION_COLUMNS, "machine", "problems"]
        if not frames:
            return pd.DataFrame(columns=columns)
        return pd.concat(frames, ignore_index=True)[columns]


def _rejected(measurement: Measurement) -> list[str]:
    answers = measurement.answers
    if answers.empty:
        return []
    return [
        f"{row.group} expression {row.instance}, {row.solver}: {row.problem}"
        for row in answers[answers["problem"] != ""].itertuples(index=False)
    ]
