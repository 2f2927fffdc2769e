"""The security files of the OPC UA server (no asyncua server, no ROS).

A security directory (default ``$ROS_HOME/drill_twin/opcua``) holds::

    server_key.pem      the server's private key (mode 0600)
    server_cert.der     its self-signed application certificate
    trusted/*.der       client certificates the server trusts
    users.txt           name:pbkdf2_sha256:iterations:salt:hash, one user a line

``drill-twin opcua cert`` creates the first two, ``drill-twin opcua trust CERT`` copies a
client's certificate into ``trusted/``, ``drill-twin opcua add-user NAME`` adds a user
(the password is read from the terminal or a file, and only its salted hash is stored).
"""
from __future__ import annotations

import hashlib
import hmac
import ipaddress
import os
import re
import secrets
from pathlib import Path
from urllib.parse import urlparse

from ..errors import ParameterError
from ..runtime.settings import ros_home

__all__ = ['APPLICATION_URI', 'default_dir', 'Paths', 'is_local', 'parse_endpoint',
           'hash_password', 'verify_password', 'add_user', 'load_users', 'make_certificate',
           'trust_certificate']

#: the server's application URI (in its certificate's subject alternative names)
APPLICATION_URI = 'urn:drill_twin:server'
ITERATIONS = 200_000
_NAME = re.compile(r'^[A-Za-z0-9_.@-]{1,64}$')
#: hosts on which a local anonymous client may write (as ROS on localhost)
LOCAL_HOSTS = ('127.0.0.1', 'localhost', '::1')


def default_dir() -> Path:
    """``$ROS_HOME/drill_twin/opcua`` (``~/.ros/drill_twin/opcua``)."""
    return Path(ros_home()) / 'drill_twin' / 'opcua'


class Paths:
    """The files of a security directory."""

    def __init__(self, directory):
        self.dir = Path(directory or default_dir()).expanduser()
        self.key = self.dir / 'server_key.pem'
        self.cert = self.dir / 'server_cert.der'
        self.trusted = self.dir / 'trusted'
        self.users = self.dir / 'users.txt'


def parse_endpoint(url: str) -> tuple:
    """``(host, port)`` of an ``opc.tcp://host:port/path`` endpoint; ParameterError with
    one line otherwise."""
    try:
        parts = urlparse(url)
        port = parts.port
    except ValueError as exc:
        raise ParameterError(f'endpoint {url!r}: {exc}') from None
    if parts.scheme != 'opc.tcp' or not parts.hostname:
        raise ParameterError(f'endpoint {url!r}: expected opc.tcp://HOST:PORT/PATH')
    return parts.hostname, port if port is not None else 4840


def is_local(url: str) -> bool:
    """True for the loopback endpoint on which an anonymous local client may write
    (127.0.0.1, localhost, ::1); any other address, another loopback address such as
    127.0.0.2 included, is treated as reachable from elsewhere: secured."""
    host, _ = parse_endpoint(url)
    return host in LOCAL_HOSTS


def hash_password(password: str, salt: bytes | None = None,
                  iterations: int = ITERATIONS) -> str:
    """``pbkdf2_sha256:iterations:salt:hash`` (hex) of a password."""
    salt = secrets.token_bytes(16) if salt is None else salt
    digest = hashlib.pbkdf2_hmac('sha256', password.encode(), salt, iterations)
    return f'pbkdf2_sha256:{iterations}:{salt.hex()}:{digest.hex()}'


def verify_password(password: str, stored: str) -> bool:
    """Whether ``password`` matches a :func:`hash_password` record (constant time)."""
    try:
        scheme, iterations, salt, digest = stored.split(':')
        if scheme != 'pbkdf2_sha256':
            return False
        got = hashlib.pbkdf2_hmac('sha256', str(password).encode(), bytes.fromhex(salt),
                                  int(iterations))
    except (ValueError, TypeError):
        return False
    return hmac.compare_digest(got.hex(), digest)


def load_users(path) -> dict:
    """name -> stored hash of a users file (missing file: no users); ParameterError with one
    line for a malformed line."""
    path = Path(path)
    if not path.is_file():
        return {}
    users = {}
    for number, line in enumerate(path.read_text().splitlines(), 1):
        line = line.strip()
        if not line or line.startswith('#'):
            continue
        name, _, stored = line.partition(':')
        if not _NAME.match(name) or stored.count(':') != 3:
            raise ParameterError(f'{path}:{number}: expected name:pbkdf2_sha256:iterations:'
                                 'salt:hash (drill-twin opcua add-user writes it)')
        users[name] = stored
    return users


def add_user(path, name: str, password: str) -> bool:
    """Add (or replace) a user; True if it replaced one."""
    if not _NAME.match(name or ''):
        raise ParameterError(f'user name {name!r}: 1-64 letters, digits, _ . @ -')
    if len(password) < 8:
        raise ParameterError('password: at least 8 characters')
    path = Path(path)
    users = load_users(path)
    replaced = name in users
    users[name] = hash_password(password)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix('.tmp')
    with open(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600), 'w') as handle:
        handle.write('# drill_twin OPC UA users (salted PBKDF2-SHA256; drill-twin opcua '
                     'add-user)\n')
        handle.writelines(f'{n}:{h}\n' for n, h in sorted(users.items()))
    os.replace(tmp, path)
    return replaced


def make_certificate(directory, hosts=('127.0.0.1', 'localhost'), days: int = 365,
                     force: bool = False) -> Paths:
    """Create the server's private key and self-signed certificate (application URI
    :data:`APPLICATION_URI`, the ``hosts`` as subject alternative names)."""
    from asyncua.crypto import cert_gen
    from cryptography import x509
    from cryptography.hazmat.primitives.serialization import Encoding
    from cryptography.x509.oid import ExtendedKeyUsageOID

    paths = Paths(directory)
    if paths.cert.exists() and not force:
        raise ParameterError(f'{paths.cert} exists (--force replaces it; clients that '
                             'trusted it must trust the new one)')
    paths.dir.mkdir(parents=True, exist_ok=True)
    paths.trusted.mkdir(exist_ok=True)
    key = cert_gen.generate_private_key()
    names = [x509.UniformResourceIdentifier(APPLICATION_URI)]
    for host in hosts:
        try:
            names.append(x509.IPAddress(ipaddress.ip_address(host)))
        except ValueError:
            names.append(x509.DNSName(host))
    cert = cert_gen.generate_self_signed_app_certificate(
        key, APPLICATION_URI, {'commonName': 'drill_twin OPC UA server',
                               'organizationName': 'drill_twin'}, names,
        extended=[ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH], days=days)
    with open(os.open(paths.key, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600), 'wb') as h:
        h.write(cert_gen.dump_private_key_as_pem(key))
    paths.cert.write_bytes(cert.public_bytes(Encoding.DER))
    return paths


def trust_certificate(directory, certificate) -> Path:
    """Copy a client's certificate (DER or PEM) into ``trusted/`` as DER; the path."""
    from cryptography import x509
    from cryptography.hazmat.primitives.serialization import Encoding

    source = Path(certificate)
    data = source.read_bytes()
    try:
        cert = (x509.load_pem_x509_certificate(data) if b'-----BEGIN' in data
                else x509.load_der_x509_certificate(data))
    except ValueError:
        raise ParameterError(f'{source}: not a certificate (DER or PEM)') from None
    paths = Paths(directory)
    paths.trusted.mkdir(parents=True, exist_ok=True)
    target = paths.trusted / (source.stem + '.der')
    target.write_bytes(cert.public_bytes(Encoding.DER))
    return target


