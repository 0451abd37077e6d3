"""``--foxglove-tls``: the endpoint as ``wss://``, for browser apps loaded over https on another machine.

A page loaded over https (app.foxglove.dev, a Lichtblick behind https) may not open ``ws://`` to another machine
(mixed content), only ``wss://``. The certificate is the team's (``pitchside team-keys FOLDER --web-names ...``
writes ``web.pem`` and ``web.key`` into the team's folder, signed by the team's CA, which each laptop trusts once) or
any certificate and key the team has. TLS is the guard's (server.foxglove.guard): the SDK's servers behind it stay
plain on loopback.
"""

from __future__ import annotations

import ssl
from pathlib import Path

TEAM_CERTIFICATE = "web.pem"  # in a folder made by `pitchside team-keys`: this machine's certificate + the team CA
TEAM_KEY = "web.key"


class TlsError(ValueError):
    """The certificate or key cannot be used; the text says which file and why."""


def certificate_files(certificate: Path, key: Path | None) -> tuple[Path, Path]:
    """(certificate, key): a team folder's web.pem and web.key, or the files given (the key beside the certificate
    in one PEM file when no key is given)."""
    if certificate.is_dir():
        if key is not None:
            raise TlsError(f"{certificate} is a folder: its {TEAM_CERTIFICATE} and {TEAM_KEY} are used; give no key")
        pair = certificate / TEAM_CERTIFICATE, certificate / TEAM_KEY
        if not pair[0].exists():
            raise TlsError(f"{certificate} has no {TEAM_CERTIFICATE}: make one with `pitchside team-keys {certificate} "
                           "--web-names NAME,ADDRESS` (the names and addresses browsers reach this machine by)")
        return pair
    return certificate, key or certificate


def server_context(certificate: Path, key: Path | None = None) -> ssl.SSLContext:
    """A TLS server context (TLS 1.2 or later) with the certificate chain and its key; TlsError if unusable."""
    cert_file, key_file = certificate_files(certificate, key)
    context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    context.minimum_version = ssl.TLSVersion.TLSv1_2
    try:
        context.load_cert_chain(cert_file, key_file)
    except FileNotFoundError as exc:
        raise TlsError(f"--foxglove-tls: {exc.filename} does not exist") from None
    except (ssl.SSLError, OSError) as exc:
        raise TlsError(f"--foxglove-tls: {cert_file} and {key_file} are not a PEM certificate and its key: "
                       f"{exc}") from None
    return context
