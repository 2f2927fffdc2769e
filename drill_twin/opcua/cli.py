"""``drill-twin opcua``: the OPC UA server's security files (docs/opcua.md).

``drill-twin opcua cert``      create the server's private key and self-signed certificate
``drill-twin opcua trust CERT`` trust a client's certificate (DER or PEM)
``drill-twin opcua add-user NAME`` add a user (password from the terminal or --password-file;
only its salted hash is stored)
"""
from __future__ import annotations

import getpass
import sys
from pathlib import Path

from ..errors import ParameterError
from . import security

__all__ = ['register']


def _dir(args):
    return args.dir or security.default_dir()


def cmd_cert(args) -> int:
    paths = security.make_certificate(_dir(args), hosts=args.host, days=args.days,
                                      force=args.force)
    print(f'server certificate {paths.cert} (key {paths.key}, application URI '
          f'{security.APPLICATION_URI}); clients must trust it')
    return 0


def cmd_trust(args) -> int:
    target = security.trust_certificate(_dir(args), args.certificate)
    print(f'trusted {target} (restart opcua_bridge to load it)')
    return 0


def _password(args) -> str:
    if args.password_file:
        text = Path(args.password_file).read_text().splitlines()
        if not text:
            raise ParameterError(f'{args.password_file}: empty (the first line is the password)')
        return text[0]
    if not sys.stdin.isatty():
        line = sys.stdin.readline().rstrip('\n')
        if not line:
            raise ParameterError('no password on standard input')
        return line
    first = getpass.getpass(f'password for {args.name}: ')
    if getpass.getpass('again: ') != first:
        raise ParameterError('the passwords differ')
    return first


def cmd_add_user(args) -> int:
    path = security.Paths(_dir(args)).users
    replaced = security.add_user(path, args.name, _password(args))
    print(f"{'replaced' if replaced else 'added'} user {args.name} in {path} (salted "
          'PBKDF2-SHA256; restart opcua_bridge to load it)')
    return 0


def register(sub):
    s = sub.add_parser('opcua', help='OPC UA server security: certificate, trusted clients, '
                       'users (docs/opcua.md)')
    osub = s.add_subparsers(dest='action', required=True)
    common = {'help': 'security directory (default $ROS_HOME/drill_twin/opcua)'}
    c = osub.add_parser('cert', help="create the server's key and self-signed certificate")
    c.add_argument('--dir', default=None, **common)
    c.add_argument('--host', action='append', default=None,
                   help='host name or address in the certificate (repeatable; default '
                   '127.0.0.1 and localhost)')
    c.add_argument('--days', type=int, default=365, help='validity [days]')
    c.add_argument('--force', action='store_true', help='replace an existing certificate')
    c.set_defaults(func=lambda a: cmd_cert(_hosts(a)))
    t = osub.add_parser('trust', help="trust a client's certificate (DER or PEM)")
    t.add_argument('certificate')
    t.add_argument('--dir', default=None, **common)
    t.set_defaults(func=cmd_trust)
    u = osub.add_parser('add-user', help='add or replace a user (salted hash)')
    u.add_argument('name')
    u.add_argument('--password-file', default=None,
                   help='read the password from the first line of this file')
    u.add_argument('--dir', default=None, **common)
    u.set_defaults(func=cmd_add_user)


def _hosts(args):
    if not args.host:
        args.host = ['127.0.0.1', 'localhost']
    if not 1 <= args.days <= 36500:
        raise ParameterError(f'--days {args.days}: must be in [1, 36500]')
    return args
