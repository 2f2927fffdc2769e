"""The live view's front door: both names of the Foxglove WebSocket protocol.

The Foxglove app and the protocol's published clients ask for the subprotocol
``foxglove.websocket.v1``; ``foxglove-sdk`` (0.16-0.30) serves the same protocol, v1,
under the name ``foxglove.sdk.v1`` and refuses the older name with HTTP 400.  This front
listens on the public port, accepts either name and relays each client's frames, both
ways and unchanged, to its own connection to the SDK server on a private loopback port.
A client that reads slowly stalls only its own relay: the SDK then drops that client's
oldest messages from its per-client backlog, as it would for a direct connection.
"""
from __future__ import annotations

import asyncio
import threading

__all__ = ['ProtocolFront', 'SUBPROTOCOLS']

#: the names accepted, the SDK's own first
SUBPROTOCOLS = ('foxglove.sdk.v1', 'foxglove.websocket.v1')


class ProtocolFront:
    """A relay on ``host:port`` (0: any free port) to the SDK server on ``upstream_port``."""

    def __init__(self, host: str, port: int, upstream_port: int):
        self._upstream = f'ws://127.0.0.1:{int(upstream_port)}'
        self._loop = asyncio.new_event_loop()
        self._ready = threading.Event()
        self._error = None
        self._server = None
        self._thread = threading.Thread(target=self._run, args=(host, int(port)),
                                        name='drill_twin live view front', daemon=True)
        self._thread.start()
        self._ready.wait(10.0)
        if self._error is not None or self._server is None:
            raise OSError(f'cannot serve the live view on {host}:{port}: {self._error}')
        self.port = self._server.sockets[0].getsockname()[1]

    def _run(self, host, port):
        asyncio.set_event_loop(self._loop)
        try:
            self._server = self._loop.run_until_complete(self._serve(host, port))
        except OSError as exc:
            self._error = exc
        finally:
            self._ready.set()
        if self._server is not None:
            self._loop.run_forever()

    async def _serve(self, host, port):
        import websockets
        return await websockets.serve(self._relay, host, port, subprotocols=SUBPROTOCOLS,
                                      max_size=None, compression=None)

    async def _relay(self, client):
        import websockets
        try:
            async with websockets.connect(self._upstream, subprotocols=[SUBPROTOCOLS[0]],
                                          max_size=None, compression=None) as upstream:
                await asyncio.gather(self._pipe(client, upstream),
                                     self._pipe(upstream, client))
        except (OSError, websockets.WebSocketException):
            pass

    @staticmethod
    async def _pipe(source, sink):
        import websockets
        try:
            async for frame in source:
                await sink.send(frame)
        except websockets.WebSocketException:
            pass
        finally:
            await sink.close()

    def close(self):
        """Stop listening and end every relay."""
        if self._server is None:
            return
        async def stop():
            self._server.close()
            await self._server.wait_closed()
        asyncio.run_coroutine_threadsafe(stop(), self._loop).result(5.0)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(5.0)
        self._server = None
