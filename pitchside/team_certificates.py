"""The team's certificate authority: it signs one TLS certificate per member, and Zenoh trusts nothing else.

Every member (router, robots, laptops) gets an ECDSA P-256 key and a certificate whose common name is the
member's name; Zenoh's access control identifies a link's other end by that common name. There is no
revocation: a lost key is answered by a new team (``pitchside team-keys --force``).
"""

from __future__ import annotations

import datetime
import ipaddress
from collections.abc import Iterable
from dataclasses import dataclass

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

VALID_DAYS = 5 * 365
# browsers refuse a server certificate valid for longer than this (Apple's platforms: 825 days, for roots a user
# installed too); a year and a month, as public CAs issue them
WEB_VALID_DAYS = 397
WEB_LOOPBACK = ("localhost", "127.0.0.1", "::1")  # always named: a browser on the laptop itself
_CLOCK_SKEW = datetime.timedelta(days=1)  # a robot whose clock is a little behind still accepts the certificate


class TeamCertificateError(Exception):
    """The team's CA files are missing, do not belong together, or cannot be read."""


@dataclass(frozen=True, slots=True)
class MemberCredentials:
    """What one member presents on its TLS links: its private key and its certificate, both PEM."""

    name: str
    role: str
    key_pem: bytes
    certificate_pem: bytes


@dataclass(frozen=True, slots=True)
class TeamAuthority:
    """The team's CA: its key signs member certificates, its certificate is every member's only trust root."""

    key: ec.EllipticCurvePrivateKey
    certificate: x509.Certificate

    @classmethod
    def create(cls, team: str) -> TeamAuthority:
        key = ec.generate_private_key(ec.SECP256R1())
        name = x509.Name([x509.NameAttribute(NameOID.ORGANIZATION_NAME, team),
                          x509.NameAttribute(NameOID.COMMON_NAME, f"{team} pitchside team CA")])
        now = datetime.datetime.now(datetime.UTC)
        certificate = (
            x509.CertificateBuilder().subject_name(name).issuer_name(name).public_key(key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - _CLOCK_SKEW).not_valid_after(now + datetime.timedelta(days=VALID_DAYS))
            .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
            .add_extension(_key_usage(sign_certificates=True), critical=True)
            .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
            .sign(key, hashes.SHA256())
        )
        return cls(key, certificate)

    @classmethod
    def load(cls, key_pem: bytes, certificate_pem: bytes) -> TeamAuthority:
        try:
            key = serialization.load_pem_private_key(key_pem, password=None)
            certificate = x509.load_pem_x509_certificate(certificate_pem)
        except ValueError as exc:
            raise TeamCertificateError(f"the team CA files cannot be read: {exc}") from None
        if not isinstance(key, ec.EllipticCurvePrivateKey) or key.public_key() != certificate.public_key():
            raise TeamCertificateError("the team CA key does not belong to the team CA certificate")
        return cls(key, certificate)

    @property
    def key_pem(self) -> bytes:
        return _private_pem(self.key)

    @property
    def certificate_pem(self) -> bytes:
        return self.certificate.public_bytes(serialization.Encoding.PEM)

    def issue(self, member: str, role: str) -> MemberCredentials:
        """A new key and certificate for one member, good both for listening and for connecting (mTLS).

        The role (robot, laptop, ...) goes into the organizational unit, so a config file says what it is for.
        """
        key = ec.generate_private_key(ec.SECP256R1())
        now = datetime.datetime.now(datetime.UTC)
        subject = x509.Name([*self.certificate.subject.get_attributes_for_oid(NameOID.ORGANIZATION_NAME),
                             x509.NameAttribute(NameOID.ORGANIZATIONAL_UNIT_NAME, role),
                             x509.NameAttribute(NameOID.COMMON_NAME, member)])
        certificate = (
            x509.CertificateBuilder().subject_name(subject).issuer_name(self.certificate.subject)
            .public_key(key.public_key()).serial_number(x509.random_serial_number())
            .not_valid_before(now - _CLOCK_SKEW).not_valid_after(now + datetime.timedelta(days=VALID_DAYS))
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .add_extension(_key_usage(sign_certificates=False), critical=True)
            .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]),
                           critical=False)
            # TLS libraries want a name here; members are told apart by the common name, not by host name
            .add_extension(x509.SubjectAlternativeName([x509.DNSName(member)]), critical=False)
            .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(self.key.public_key()), critical=False)
            .sign(self.key, hashes.SHA256())
        )
        return MemberCredentials(member, role, _private_pem(key), certificate.public_bytes(serialization.Encoding.PEM))


    def issue_web(self, names: Iterable[str]) -> MemberCredentials:
        """A TLS server certificate for a web server of the team (the Foxglove endpoint's wss://), valid for the
        host names and addresses given (and loopback), as browsers check them; its PEM holds the team CA after it, so
        a server sends the whole chain."""
        wanted = list(dict.fromkeys([*names, *WEB_LOOPBACK]))
        alternatives: list[x509.GeneralName] = []
        for name in wanted:
            try:
                alternatives.append(x509.IPAddress(ipaddress.ip_address(name.strip("[]"))))
            except ValueError:
                alternatives.append(x509.DNSName(name))
        key = ec.generate_private_key(ec.SECP256R1())
        now = datetime.datetime.now(datetime.UTC)
        subject = x509.Name([*self.certificate.subject.get_attributes_for_oid(NameOID.ORGANIZATION_NAME),
                             x509.NameAttribute(NameOID.ORGANIZATIONAL_UNIT_NAME, "web"),
                             x509.NameAttribute(NameOID.COMMON_NAME, wanted[0])])
        certificate = (
            x509.CertificateBuilder().subject_name(subject).issuer_name(self.certificate.subject)
            .public_key(key.public_key()).serial_number(x509.random_serial_number())
            .not_valid_before(now - _CLOCK_SKEW).not_valid_after(now + datetime.timedelta(days=WEB_VALID_DAYS))
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .add_extension(_key_usage(sign_certificates=False), critical=True)
            .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
            .add_extension(x509.SubjectAlternativeName(alternatives), critical=False)
            .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
            .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(self.key.public_key()), critical=False)
            .sign(self.key, hashes.SHA256())
        )
        chain = certificate.public_bytes(serialization.Encoding.PEM) + self.certificate_pem
        return MemberCredentials(wanted[0], "web", _private_pem(key), chain)


def member_credentials(key_pem: bytes, certificate_pem: bytes) -> MemberCredentials:
    """A member's credentials from its key and certificate; the name and role are read from the certificate."""
    try:
        subject = x509.load_pem_x509_certificate(certificate_pem).subject
    except ValueError as exc:
        raise TeamCertificateError(f"not a PEM certificate: {exc}") from None

    def attribute(oid: x509.ObjectIdentifier) -> str:
        values = subject.get_attributes_for_oid(oid)
        return str(values[0].value) if values else ""

    return MemberCredentials(attribute(NameOID.COMMON_NAME), attribute(NameOID.ORGANIZATIONAL_UNIT_NAME), key_pem,
                             certificate_pem)


def _private_pem(key: ec.EllipticCurvePrivateKey) -> bytes:
    return key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                             serialization.NoEncryption())


def _key_usage(sign_certificates: bool) -> x509.KeyUsage:
    return x509.KeyUsage(digital_signature=not sign_certificates, content_commitment=False, key_encipherment=False,
                         data_encipherment=False, key_agreement=False, key_cert_sign=sign_certificates,
                         crl_sign=sign_certificates, encipher_only=False, decipher_only=False)
