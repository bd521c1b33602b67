"""A daemon's process imports asyncio without ssl (OpenSSL stays unmapped) and asyncio's
TLS still works the moment something imports ssl: checked in fresh interpreters, with a
real TLS connection through asyncio to a server with a self-signed certificate."""

from __future__ import annotations

import datetime
import json
import subprocess
import sys
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

from actorswarm.daemon.ssl_deferred import ASYNCIO_SSL_USERS, import_asyncio_without_ssl

_TLS_AFTER_THE_DAEMON = """
import json, sys
import actorswarm.daemon
import asyncio
seen = {"ssl_before": "ssl" in sys.modules,
        "mapped_before": "libssl.so" in open("/proc/self/maps").read()}
import ssl  # what a plugin that opens a TLS connection does

async def main() -> str:
    server_ctx = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    server_ctx.load_cert_chain(sys.argv[1], sys.argv[2])
    client_ctx = ssl.create_default_context(cafile=sys.argv[1])

    async def echo(reader, writer):
        writer.write(await reader.readline())
        await writer.drain()
        writer.close()

    server = await asyncio.start_server(echo, "127.0.0.1", 0, ssl=server_ctx)
    port = server.sockets[0].getsockname()[1]
    reader, writer = await asyncio.open_connection(
        "127.0.0.1", port, ssl=client_ctx, server_hostname="localhost")
    writer.write(b"over tls\\n")
    line = await reader.readline()
    cipher = writer.get_extra_info("cipher")
    writer.close()
    server.close()
    return line.decode().strip() + " " + str(cipher is not None)

seen["echo"] = asyncio.run(main())
seen["mapped_after"] = "libssl.so" in open("/proc/self/maps").read()
print(json.dumps(seen))
"""


def _certificate(directory: Path) -> tuple[Path, Path]:
    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "localhost")])
    now = datetime.datetime.now(datetime.UTC)
    cert = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(now + datetime.timedelta(days=1))
        .add_extension(x509.SubjectAlternativeName([x509.DNSName("localhost")]), critical=False)
        .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
        .sign(key, hashes.SHA256())
    )
    cert_path, key_path = directory / "cert.pem", directory / "key.pem"
    cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    key_path.write_bytes(
        key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        )
    )
    return cert_path, key_path


def test_asyncio_tls_works_once_ssl_is_imported_after_the_daemon(tmp_path: Path) -> None:
    cert, key = _certificate(tmp_path)
    result = subprocess.run(
        [sys.executable, "-c", _TLS_AFTER_THE_DAEMON, str(cert), str(key)],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    seen = json.loads(result.stdout.strip().splitlines()[-1])
    assert seen == {
        "ssl_before": False,
        "mapped_before": False,
        "echo": "over tls True",
        "mapped_after": True,
    }


def test_without_the_deferral_asyncio_tls_would_not_work() -> None:
    """What the hand-over mends: asyncio imported while ssl could not be keeps None."""
    code = (
        "import sys, json\n"
        "sys.modules['ssl'] = None\n"
        "import asyncio\n"
        "del sys.modules['ssl']\n"
        "import ssl\n"
        f"print(json.dumps([sys.modules[m].ssl is None for m in {ASYNCIO_SSL_USERS!r}]))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    )
    assert json.loads(out.stdout) == [True, True, True]
    handed = subprocess.run(
        [sys.executable, "-c",
         "import json, sys\nimport actorswarm.daemon\nimport ssl\n"
         f"print(json.dumps([sys.modules[m].ssl is ssl for m in {ASYNCIO_SSL_USERS!r}]))\n"],
        capture_output=True, text=True, timeout=60, check=True,
    )  # fmt: skip
    assert json.loads(handed.stdout) == [True, True, True]


def test_a_process_that_already_imported_asyncio_is_left_alone() -> None:
    assert "asyncio" in sys.modules  # pytest's process
    meta_path = list(sys.meta_path)
    assert import_asyncio_without_ssl() is False
    assert sys.meta_path == meta_path
