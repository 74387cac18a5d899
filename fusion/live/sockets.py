"""ZeroMQ socket set-up shared by the server and its clients: the shared token as PLAIN credentials.

With a token, the server's sockets require ZeroMQ's PLAIN mechanism (user ``mocap-bench``, the
token as password), checked by a ZAP authenticator thread of the server's context; clients present
the same credentials. PLAIN does not encrypt: it keeps strangers out of a lab network, nothing more.
"""

from __future__ import annotations

import zmq
from zmq.auth.thread import ThreadAuthenticator

USER = "mocap-bench"
"""PLAIN user name of every client."""


def start_authenticator(ctx: zmq.Context, token: str) -> ThreadAuthenticator:
    """Start the ZAP authenticator that accepts clients presenting ``token``; stop it after the sockets."""
    auth = ThreadAuthenticator(ctx)
    auth.start()
    auth.configure_plain(domain="*", passwords={USER: token})
    return auth


def secure(socket: zmq.Socket, token: str | None, *, server: bool) -> zmq.Socket:
    """``socket`` set up for PLAIN with ``token`` (as server or client); unchanged without a token."""
    if token is not None:
        if server:
            socket.plain_server = True
        else:
            socket.plain_username = USER.encode()
            socket.plain_password = token.encode()
    return socket
