"""TLS for a run's router: a certificate authority made for the run, and the router's certificate signed by it.

The CA's private key exists only in the supervisor's memory for the moment it signs; clients trust this CA alone
(comms.bus.access.client_config), so a router that is not the run's own cannot pose as it, and no site PKI is needed.
Made with `cryptography` (ECDSA P-256, which rustls, Zenoh's TLS, accepts).
"""

from __future__ import annotations

import datetime
import ipaddress
import socket
from dataclasses import dataclass

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

VALID = datetime.timedelta(days=366)  # longer than any run; the CA is thrown away with the run anyway


@dataclass(frozen=True, slots=True)
class RouterTls:
    """PEM texts: the run's CA certificate (for clients), the router's certificate and private key."""

    ca: str
    certificate: str
    key: str


def _name(common_name: str) -> x509.Name:
    return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common_name)])


def _names(hosts: list[str]) -> list[x509.GeneralName]:
    """Subject alternative names: each host as an IP address where it is one, else as a DNS name."""
    names: list[x509.GeneralName] = []
    for host in dict.fromkeys(hosts):  # unique, in order
        try:
            names.append(x509.IPAddress(ipaddress.ip_address(host)))
        except ValueError:
            names.append(x509.DNSName(host))
    return names


def router_tls(hosts: list[str] | None = None) -> RouterTls:
    """A fresh CA and the router's certificate, naming this machine (and hosts) for clients that check names."""
    now = datetime.datetime.now(datetime.UTC)
    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca_cert = (
        x509.CertificateBuilder().subject_name(_name("cpf run CA")).issuer_name(_name("cpf run CA"))
        .public_key(ca_key.public_key()).serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(hours=1)).not_valid_after(now + VALID)
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(x509.KeyUsage(False, False, False, False, False, True, True, False, False), critical=True)
        .sign(ca_key, hashes.SHA256())
    )  # fmt: skip
    key = ec.generate_private_key(ec.SECP256R1())
    machine = [socket.gethostname(), socket.getfqdn(), "localhost", "127.0.0.1", "::1"]
    cert = (
        x509.CertificateBuilder().subject_name(_name("cpf run router")).issuer_name(ca_cert.subject)
        .public_key(key.public_key()).serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(hours=1)).not_valid_after(now + VALID)
        .add_extension(x509.SubjectAlternativeName(_names([*(hosts or []), *machine])), critical=False)
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .sign(ca_key, hashes.SHA256())
    )  # fmt: skip
    pem = serialization.Encoding.PEM
    key_pem = key.private_bytes(pem, serialization.PrivateFormat.PKCS8, serialization.NoEncryption())
    return RouterTls(ca_cert.public_bytes(pem).decode(), cert.public_bytes(pem).decode(), key_pem.decode())
