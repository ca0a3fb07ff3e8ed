"""The fleet's certificate authority: make it, issue a certificate per node, revoke one.

A PKI folder holds::

    D/ca.pem            the fleet CA's certificate (every member trusts it)
    D/crl.pem           the revocation list, signed by the CA (every member reads it)
    D/ID.pem, D/ID.key  one member's certificate and key (the key 0600)
    D/members.json      every certificate issued: id, role, serial, until, revoked (no
                        secret in it; routers read it to give each member its own keys)
    D/private/ca.key    the CA's key (0600, in a 0700 folder): used by this module alone

A member's certificate names it: the subject's common name is the node id, the
organisational unit its role (``ROLES``), the organisation the fleet. A node's id on
every link is the one its certificate names (``objectplaces.security.identity``).
Keys are ECDSA P-256: small, and quick to handshake. Nothing here is secret but the
keys, and each key is written once, by its owner's umask-proof ``0600`` open.
"""

from __future__ import annotations

import dataclasses
import datetime
import ipaddress
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Final

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from objectplaces.security.errors import CredentialError

__all__ = [
    "CA_FILE",
    "CRL_FILE",
    "MEMBERS_FILE",
    "ROLES",
    "Issued",
    "init_ca",
    "issue",
    "issued",
    "revoke",
    "write_private",
]

ROLES: Final = ("node", "agv", "control", "router", "master")
"""A member's role: ``node`` (any middleware node), ``agv`` (a vehicle), ``control`` (the
transport base and dashboard), ``router`` (a Zenoh router), ``master`` (a VDA 5050 master
control)."""

CA_FILE: Final = "ca.pem"
CRL_FILE: Final = "crl.pem"
MEMBERS_FILE: Final = "members.json"
_CA_KEY: Final = "private/ca.key"
_ID: Final = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.:@+=-]{0,63}")
_FLEET: Final = re.compile(r"[A-Za-z0-9_.-]{1,64}")
_CA_DAYS: Final = 3650
_CRL_DAYS: Final = 3650  # as long as the CA: a fleet runs for years between revocations


@dataclass(frozen=True, slots=True)
class Issued:
    """One certificate the CA issued."""

    node_id: str
    role: str
    serial: int
    not_after: str
    revoked: str | None = None


def write_private(path: Path, data: bytes) -> None:
    """Write ``data`` to a new file at ``path`` that only its owner can read (0600)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _write_public(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)  # readers (nodes watching the CRL) never see half a file


def _now() -> datetime.datetime:
    return datetime.datetime.now(datetime.UTC)


def init_ca(directory: Path, *, fleet: str = "default") -> Path:
    """Make a fleet CA in ``directory`` (created 0700 if missing) with an empty CRL.

    Returns:
        The CA certificate's path.

    Raises:
        CredentialError: the folder holds a CA already, or the fleet name is not valid.
    """
    if not _FLEET.fullmatch(fleet):
        raise CredentialError(f"fleet name must be 1-64 of A-Z a-z 0-9 _ . -, got {fleet!r}")
    if (directory / CA_FILE).exists():
        raise CredentialError(f"{directory / CA_FILE} exists: this folder has a CA already")
    (directory / "private").mkdir(mode=0o700, parents=True, exist_ok=True)
    os.chmod(directory / "private", 0o700)
    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name(
        [
            x509.NameAttribute(NameOID.ORGANIZATION_NAME, fleet),
            x509.NameAttribute(NameOID.COMMON_NAME, f"objectplaces fleet CA {fleet}"),
        ]
    )
    now = _now()
    cert = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(now + datetime.timedelta(days=_CA_DAYS))
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(
            x509.KeyUsage(
                digital_signature=False,
                content_commitment=False,
                key_encipherment=False,
                data_encipherment=False,
                key_agreement=False,
                key_cert_sign=True,
                crl_sign=True,
                encipher_only=False,
                decipher_only=False,
            ),
            critical=True,
        )
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
        .sign(key, hashes.SHA256())
    )
    write_private(directory / _CA_KEY, _key_pem(key))
    _write_public(directory / CA_FILE, cert.public_bytes(serialization.Encoding.PEM))
    _write_index(directory, [])
    _write_crl(directory, cert, key, [])
    return directory / CA_FILE


def issue(
    directory: Path,
    node_id: str,
    *,
    role: str = "node",
    days: int = 365,
    addresses: tuple[str, ...] = (),
) -> tuple[Path, Path]:
    """Issue a certificate and key for ``node_id`` as ``D/ID.pem`` and ``D/ID.key``.

    Args:
        directory: the PKI folder (``init_ca`` made it).
        node_id: the member's id (1-64 of letters, digits and ``_.:@+=-``).
        role: one of ``ROLES``.
        days: how long the certificate is valid.
        addresses: host names or IP addresses it serves on (a router's, so that clients
            can check they reached it); also written as subject alternative names.

    Returns:
        The certificate's and the key's paths.

    Raises:
        CredentialError: a bad id, role or address; an id issued before and not
            revoked; no CA in ``directory``.
    """
    if not isinstance(node_id, str) or not _ID.fullmatch(node_id):
        raise CredentialError(
            f"node id must be 1-64 of A-Z a-z 0-9 _ . : @ + = - (not starting with a "
            f"sign), got {node_id!r}"
        )
    if role not in ROLES:
        raise CredentialError(f"role must be one of {', '.join(ROLES)}, got {role!r}")
    if not 1 <= days <= 3650:
        raise CredentialError(f"days must be in 1..3650, got {days!r}")
    ca_cert, ca_key = _load_ca(directory)
    index = _read_index(directory)
    revoked = [e for e in index if e.node_id == node_id and e.revoked is not None]
    if revoked:
        raise CredentialError(
            f"{node_id!r} was revoked at {revoked[-1].revoked}: a revoked id is not issued "
            "again (Zenoh's access control tells certificates apart by id alone, so the "
            "revoked one would be let back in); issue the replacement under a new id"
        )
    earlier = _current(index, node_id)
    if earlier is not None:
        raise CredentialError(
            f"{node_id!r} holds a certificate already (serial {earlier.serial}); "
            f"revoke it first: objectplaces pki revoke --dir {directory} {node_id}"
        )
    fleet = ca_cert.subject.get_attributes_for_oid(NameOID.ORGANIZATION_NAME)[0].value
    key = ec.generate_private_key(ec.SECP256R1())
    now = _now()
    serial = x509.random_serial_number()
    not_after = now + datetime.timedelta(days=days)
    builder = (
        x509.CertificateBuilder()
        .subject_name(
            x509.Name(
                [
                    x509.NameAttribute(NameOID.ORGANIZATION_NAME, str(fleet)),
                    x509.NameAttribute(NameOID.ORGANIZATIONAL_UNIT_NAME, role),
                    x509.NameAttribute(NameOID.COMMON_NAME, node_id),
                ]
            )
        )
        .issuer_name(ca_cert.subject)
        .public_key(key.public_key())
        .serial_number(serial)
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(not_after)
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(
            x509.ExtendedKeyUsage(
                [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]
            ),
            critical=False,
        )
        .add_extension(
            x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_key.public_key()),
            critical=False,
        )
    )
    names = _alternative_names(addresses)
    if names:
        builder = builder.add_extension(x509.SubjectAlternativeName(names), critical=False)
    cert = builder.sign(ca_key, hashes.SHA256())
    key_path, cert_path = directory / f"{node_id}.key", directory / f"{node_id}.pem"
    write_private(key_path, _key_pem(key))
    _write_public(cert_path, cert.public_bytes(serialization.Encoding.PEM))
    index.append(Issued(node_id, role, serial, not_after.isoformat(timespec="seconds")))
    _write_index(directory, index)
    return cert_path, key_path


def revoke(directory: Path, node_id: str) -> Issued:
    """Revoke ``node_id``'s certificate: it goes on the CRL, which is signed anew.

    Members re-read the CRL when it changes and close the revoked member's links.

    Raises:
        CredentialError: no such member, or it was revoked already.
    """
    ca_cert, ca_key = _load_ca(directory)
    index = _read_index(directory)
    entry = _current(index, node_id)
    if entry is None:
        known = ", ".join(sorted({e.node_id for e in index if e.revoked is None})) or "none"
        raise CredentialError(
            f"{node_id!r} holds no certificate that is not revoked (current: {known})"
        )
    done = dataclasses.replace(entry, revoked=_now().isoformat(timespec="seconds"))
    index[index.index(entry)] = done
    _write_index(directory, index)
    _write_crl(directory, ca_cert, ca_key, index)
    return done


def issued(directory: Path) -> list[Issued]:
    """Every certificate the CA in ``directory`` issued, revoked ones too, by id (reads
    ``members.json``: no CA key needed, so routers call it too).

    Raises:
        CredentialError: no CA in ``directory``, or an unreadable ``members.json``.
    """
    if not (directory / CA_FILE).is_file():
        raise CredentialError(f"{directory} holds no fleet CA (no {CA_FILE})")
    return sorted(_read_index(directory), key=lambda e: (e.node_id, e.revoked is None))


def _current(index: list[Issued], node_id: str) -> Issued | None:
    return next((e for e in index if e.node_id == node_id and e.revoked is None), None)


def _alternative_names(addresses: tuple[str, ...]) -> list[x509.GeneralName]:
    names: list[x509.GeneralName] = []
    for address in addresses:
        try:
            names.append(x509.IPAddress(ipaddress.ip_address(address)))
        except ValueError:
            if not re.fullmatch(r"[A-Za-z0-9]([A-Za-z0-9.-]{0,252})", address):
                raise CredentialError(
                    f"address must be an IP address or a host name, got {address!r}"
                ) from None
            names.append(x509.DNSName(address))
    return names


def _key_pem(key: ec.EllipticCurvePrivateKey) -> bytes:
    return key.private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.NoEncryption(),
    )


def _load_ca(directory: Path) -> tuple[x509.Certificate, ec.EllipticCurvePrivateKey]:
    cert_path, key_path = directory / CA_FILE, directory / _CA_KEY
    if not cert_path.is_file() or not key_path.is_file():
        raise CredentialError(
            f"{directory} holds no fleet CA (no {CA_FILE} or {_CA_KEY}); "
            f"make one with: objectplaces pki init --dir {directory}"
        )
    from objectplaces.security.secrets import check_private_file

    check_private_file(key_path, what="CA key")
    try:
        cert = x509.load_pem_x509_certificate(cert_path.read_bytes())
        key = serialization.load_pem_private_key(key_path.read_bytes(), password=None)
    except (OSError, ValueError) as exc:
        raise CredentialError(f"{directory}: the CA cannot be read: {exc}") from None
    if not isinstance(key, ec.EllipticCurvePrivateKey):
        raise CredentialError(f"{key_path}: not an EC key")
    return cert, key


def _read_index(directory: Path) -> list[Issued]:
    path = directory / MEMBERS_FILE
    try:
        return [Issued(**entry) for entry in json.loads(path.read_text())]
    except FileNotFoundError:
        return []
    except (OSError, ValueError, TypeError) as exc:
        raise CredentialError(f"{path}: not an index of certificates: {exc}") from None


def _write_index(directory: Path, index: list[Issued]) -> None:
    entries = [dataclasses.asdict(e) for e in index]
    _write_public(directory / MEMBERS_FILE, json.dumps(entries, indent=1).encode())


def _write_crl(
    directory: Path,
    ca_cert: x509.Certificate,
    ca_key: ec.EllipticCurvePrivateKey,
    index: list[Issued],
) -> None:
    now = _now()
    builder = (
        x509.CertificateRevocationListBuilder()
        .issuer_name(ca_cert.subject)
        .last_update(now - datetime.timedelta(minutes=5))
        .next_update(now + datetime.timedelta(days=_CRL_DAYS))
    )
    for entry in index:
        if entry.revoked is not None:
            builder = builder.add_revoked_certificate(
                x509.RevokedCertificateBuilder()
                .serial_number(entry.serial)
                .revocation_date(datetime.datetime.fromisoformat(entry.revoked))
                .build()
            )
    crl = builder.sign(ca_key, hashes.SHA256())
    _write_public(directory / CRL_FILE, crl.public_bytes(serialization.Encoding.PEM))
