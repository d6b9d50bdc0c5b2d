"""The sweep's local Dask cluster is the studio's alone: another process on the machine cannot
connect to it (TLS with this run's credentials; a plain client is refused), and it answers no
HTTP (Dask's servers on the scheduler and workers are closed). The studio's own client works.

The intruder is a separate Python process with a plain `distributed.Client`, as another user or
program on the machine would use it."""

from __future__ import annotations

import socket
import subprocess
import sys
import textwrap

import pytest

from app.sweep_engine import SweepEngine


@pytest.fixture(scope="module")
def engine():
    started = SweepEngine(n_workers=1)
    try:
        yield started
    finally:
        started.close()


def _accepts(host: str, port: int) -> bool:
    with socket.socket() as sock:
        sock.settimeout(5.0)
        return sock.connect_ex((host, port)) == 0


def test_the_studio_s_own_client_runs_tasks(engine: SweepEngine) -> None:
    assert engine.address.startswith("tls://127.0.0.1:")
    assert engine.client.submit(pow, 3, 4, pure=False).result(timeout=120) == 81


@pytest.mark.parametrize("scheme", ["tls", "tcp"])
def test_a_client_without_the_credentials_is_refused(engine: SweepEngine, scheme: str) -> None:
    address = engine.address.replace("tls://", f"{scheme}://")
    intruder = textwrap.dedent(
        f"""
        import sys
        from distributed import Client
        try:
            client = Client({address!r}, timeout=10)
        except Exception as error:
            print("refused:", type(error).__name__)
            sys.exit(0)
        print("connected: ran", client.submit(sum, [1, 2], pure=False).result(timeout=30))
        sys.exit(1)
        """
    )
    run = subprocess.run(
        [sys.executable, "-c", intruder], capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, f"a plain client got in: {run.stdout}{run.stderr[-2000:]}"
    assert "refused" in run.stdout


def test_no_http_server_listens(engine: SweepEngine) -> None:
    cluster = engine._cluster
    ports = [cluster.scheduler.http_server.port]
    ports += engine.client.run(lambda dask_worker: dask_worker.http_server.port).values()
    for port in ports:
        assert port and not _accepts("127.0.0.1", port), f"an HTTP server answers on {port}"


def test_sweeping_on_the_tls_scheduler_without_credentials_is_one_line(
    engine: SweepEngine,
) -> None:
    from app.sweep_engine import SweepEngineError

    with pytest.raises(SweepEngineError, match="needs TLS credentials") as refused:
        SweepEngine(engine.address)
    assert "\n" not in str(refused.value)
