"""A member's certified identity: its certificate, key and the fleet CA, checked once at
start, and the TLS contexts every transport builds from them.

``Identity.from_pki(D, ID)`` reads ``D/ca.pem``, ``D/ID.pem``, ``D/ID.key`` and
``D/crl.pem`` and refuses, naming the path and the reason, a file that is missing or
unreadable, a key readable by others or not matching the certificate, a certificate
that has expired, is not yet valid, was signed by another CA, names another id, or is
revoked. ``peer_of`` reads who a peer is from the certificate its TLS handshake proved:
a node's id on a link is its certificate's, whatever it says in its hello.

``Revocations`` keeps the CRL's revoked serials, re-read when the file changes (a
revocation reaches running members within one ``refresh``).
"""

from __future__ import annotations

import datetime
import ssl
from dataclasses import dataclass, field
from pathlib import Path
from typing import Final

from cryptography import x509
from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

from objectplaces.security.errors import CredentialError
from objectplaces.security.pki import CA_FILE, CRL_FILE, ROLES
from objectplaces.security.secrets import check_private_file

__all__ = ["Identity", "PeerCertificate", "Revocations", "peer_of"]

_TLS_MIN: Final = ssl.TLSVersion.TLSv1_3


@dataclass(frozen=True, slots=True)
class PeerCertificate:
    """Who a TLS peer proved to be: its id, role and fleet, and its certificate's serial."""

    node_id: str
    role: str
    fleet: str
    serial: int


class Revocations:
    """The revoked serials of a CRL file, re-read when the file changes.

    Args:
        path: the CRL (PEM), signed by ``ca``.
        ca: the fleet CA; a CRL it did not sign is refused.
    """

    def __init__(self, path: Path, ca: x509.Certificate) -> None:
        self.path = path
        self._ca = ca
        self._stamp: tuple[int, int] | None = None
        self._serials: frozenset[int] = frozenset()
        self.refresh()

    def refresh(self) -> bool:
        """Re-read the file if it changed since the last read.

        Returns:
            True if the revoked serials changed.

        Raises:
            CredentialError: the file is gone, unreadable, or not signed by the CA.
                Running members catch this and keep the list they had.
        """
        try:
            status = self.path.stat()
        except OSError as exc:
            raise CredentialError(f"revocation list {self.path}: {exc.strerror}") from None
        stamp = (status.st_mtime_ns, status.st_size)
        if stamp == self._stamp:
            return False
        try:
            crl = x509.load_pem_x509_crl(self.path.read_bytes())
        except (OSError, ValueError) as exc:
            raise CredentialError(f"revocation list {self.path}: cannot be read: {exc}") from None
        public = self._ca.public_key()
        assert isinstance(public, ec.EllipticCurvePublicKey)
        if crl.issuer != self._ca.subject or not crl.is_signature_valid(public):
            raise CredentialError(f"revocation list {self.path}: not signed by the fleet CA")
        self._stamp = stamp
        serials = frozenset(r.serial_number for r in crl)
        changed = serials != self._serials
        self._serials = serials
        return changed

    def __contains__(self, serial: object) -> bool:
        return serial in self._serials

    @property
    def serials(self) -> frozenset[int]:
        """The serials revoked, as last read."""
        return self._serials


@dataclass(frozen=True)
class Identity:
    """A member's certificate, key and fleet CA; made by ``from_pki`` or ``from_files``.

    Attributes:
        node_id: the id the certificate names (its subject's common name).
        role: the role it names (``objectplaces.security.pki.ROLES``).
        fleet: the fleet it belongs to (its subject's organisation).
        ca: the fleet CA certificate's path.
        cert: the member's certificate's path.
        key: the member's key's path (0600).
        crl: the revocation list's path (None: no revocations are checked).
    """

    node_id: str
    role: str
    fleet: str
    ca: Path
    cert: Path
    key: Path
    crl: Path | None
    revocations: Revocations | None = field(default=None, compare=False, repr=False)

    @classmethod
    def from_pki(cls, directory: Path | str, node_id: str) -> Identity:
        """The identity of ``node_id`` in the PKI folder ``directory`` (``objectplaces pki``).

        Raises:
            CredentialError: any file missing or unusable; the message names it and why.
        """
        d = Path(directory)
        if not d.is_dir():
            raise CredentialError(f"PKI folder {d}: not a folder")
        crl = d / CRL_FILE
        return cls.from_files(
            ca=d / CA_FILE,
            cert=d / f"{node_id}.pem",
            key=d / f"{node_id}.key",
            crl=crl if crl.exists() else None,
            node_id=node_id,
        )

    @classmethod
    def from_files(
        cls,
        *,
        ca: Path,
        cert: Path,
        key: Path,
        crl: Path | None = None,
        node_id: str | None = None,
    ) -> Identity:
        """The identity in these files; ``node_id``, when given, must be the certificate's.

        Raises:
            CredentialError: a file missing or unusable; the message names it and why.
        """
        ca_cert = _load_certificate(ca, "CA certificate")
        own = _load_certificate(cert, "certificate")
        check_private_file(key, what="key")
        try:
            private = serialization.load_pem_private_key(key.read_bytes(), password=None)
        except (OSError, ValueError, TypeError) as exc:
            raise CredentialError(f"key {key}: cannot be read: {exc}") from None
        if private.public_key() != own.public_key():
            raise CredentialError(f"key {key} does not match certificate {cert}")
        _check_signed_by(own, cert, ca_cert, ca)
        _check_valid_now(own, cert)
        _check_valid_now(ca_cert, ca)
        peer = _describe(own)
        if peer is None:
            raise CredentialError(
                f"certificate {cert} names no member (common name, role and fleet); "
                "issue it with: objectplaces pki issue"
            )
        if node_id is not None and peer.node_id != node_id:
            raise CredentialError(f"certificate {cert} names {peer.node_id!r}, not {node_id!r}")
        revocations = Revocations(crl, ca_cert) if crl is not None else None
        if revocations is not None and peer.serial in revocations:
            raise CredentialError(f"certificate {cert} of {peer.node_id!r} is revoked ({crl})")
        return cls(peer.node_id, peer.role, peer.fleet, ca, cert, key, crl, revocations)

    def server_context(self) -> ssl.SSLContext:
        """A TLS 1.3 server context that demands a certificate of the fleet CA."""
        context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
        self._configure(context)
        return context

    def client_context(self) -> ssl.SSLContext:
        """A TLS 1.3 client context that presents this member's certificate and trusts
        the fleet CA alone. Host names are not checked: the peer's id is, by the caller
        (``peer_of``), against whom it meant to reach."""
        context = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
        context.check_hostname = False
        self._configure(context)
        return context

    def _configure(self, context: ssl.SSLContext) -> None:
        context.minimum_version = _TLS_MIN
        context.verify_mode = ssl.CERT_REQUIRED
        context.load_verify_locations(cafile=str(self.ca))
        context.load_cert_chain(str(self.cert), str(self.key))

    def is_revoked(self, peer: PeerCertificate) -> bool:
        """Whether ``peer``'s certificate is on the revocation list, as last read."""
        return self.revocations is not None and peer.serial in self.revocations

    def refresh_revocations(self) -> bool:
        """Re-read the revocation list if it changed; True if what it revokes changed.

        A list that cannot be read now keeps the one read before (it is replaced while
        ``objectplaces pki revoke`` writes it; the next refresh reads it).
        """
        if self.revocations is None:
            return False
        try:
            return self.revocations.refresh()
        except CredentialError:
            return False


def peer_of(ssl_object: ssl.SSLObject | ssl.SSLSocket | None) -> PeerCertificate | None:
    """Who the peer of a TLS connection proved to be; None without a member certificate."""
    if ssl_object is None:
        return None
    der = ssl_object.getpeercert(binary_form=True)
    if not der:
        return None
    try:
        return _describe(x509.load_der_x509_certificate(der))
    except ValueError:
        return None


def _describe(cert: x509.Certificate) -> PeerCertificate | None:
    subject = cert.subject

    def one(oid: x509.ObjectIdentifier) -> str | None:
        values = subject.get_attributes_for_oid(oid)
        return str(values[0].value) if len(values) == 1 else None

    node_id = one(NameOID.COMMON_NAME)
    role = one(NameOID.ORGANIZATIONAL_UNIT_NAME)
    fleet = one(NameOID.ORGANIZATION_NAME)
    if not node_id or role not in ROLES or not fleet:
        return None
    assert role is not None
    return PeerCertificate(node_id, role, fleet, cert.serial_number)


def _load_certificate(path: Path, what: str) -> x509.Certificate:
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise CredentialError(f"{what} {path}: cannot be read: {exc.strerror}") from None
    try:
        return x509.load_pem_x509_certificate(data)
    except ValueError as exc:
        raise CredentialError(f"{what} {path}: not a PEM certificate: {exc}") from None


def _check_signed_by(
    cert: x509.Certificate, path: Path, ca: x509.Certificate, ca_path: Path
) -> None:
    try:
        cert.verify_directly_issued_by(ca)
    except (ValueError, TypeError, InvalidSignature) as exc:
        raise CredentialError(
            f"certificate {path} is not signed by the fleet CA {ca_path} ({type(exc).__name__})"
        ) from None


def _check_valid_now(cert: x509.Certificate, path: Path) -> None:
    now = datetime.datetime.now(datetime.UTC)
    if now > cert.not_valid_after_utc:
        raise CredentialError(
            f"certificate {path} expired on {cert.not_valid_after_utc:%Y-%m-%d %H:%M} UTC"
        )
    if now < cert.not_valid_before_utc:
        raise CredentialError(
            f"certificate {path} is not valid before {cert.not_valid_before_utc:%Y-%m-%d %H:%M} UTC"
        )
