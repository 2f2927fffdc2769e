"""A minimal, independent Foxglove WebSocket client (``foxglove.websocket.v1``) for the
live-view tests: the ``websockets`` package, no foxglove-sdk code.

Protocol (github.com/foxglove/ws-protocol, spec v1): the client offers only the
subprotocol of the ws-protocol spec, ``foxglove.websocket.v1`` (the live view's front
accepts it beside foxglove-sdk's own name ``foxglove.sdk.v1``: drill_twin/live/compat.py);
the server's
JSON ``serverInfo`` and ``advertise`` (channels with ``id``, ``topic``, ``encoding``,
``schemaName``, ``schema``, ``schemaEncoding``); the client's JSON ``subscribe``
(``subscriptions``: ``id``, ``channelId``); the server's binary message data: opcode
0x01, uint32 subscription id, uint64 log time [ns], payload (little endian).
"""
import json
import struct
import threading
import time

from websockets.sync.client import connect

SUBPROTOCOLS = ('foxglove.websocket.v1',)
MESSAGE_DATA = 0x01


class FoxgloveClient:
    """Connects to ``ws://127.0.0.1:PORT``; :meth:`pump` reads what arrives."""

    def __init__(self, port: int, timeout: float = 10.0):
        self.ws = connect(f'ws://127.0.0.1:{port}', subprotocols=list(SUBPROTOCOLS),
                          open_timeout=timeout, max_size=None)
        self.subprotocol = self.ws.subprotocol
        self.server_info = None
        self.channels = {}          # channel id -> advertisement
        self.subscriptions = {}     # subscription id -> channel id
        self.messages = {}          # channel id -> [(log time ns, payload bytes)]
        self.texts = []

    def by_topic(self, topic: str) -> dict:
        return next(c for c in self.channels.values() if c['topic'] == topic)

    def pump(self, seconds: float = 0.05) -> int:
        """Read everything that arrives within ``seconds``; returns the frames read."""
        deadline = time.monotonic() + seconds
        n = 0
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return n
            try:
                frame = self.ws.recv(timeout=left)
            except TimeoutError:
                return n
            n += 1
            self._handle(frame)

    def pump_until(self, condition, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.pump(0.05)
            if condition():
                return True
        return False

    def _handle(self, frame):
        if isinstance(frame, str):
            msg = json.loads(frame)
            self.texts.append(msg)
            if msg.get('op') == 'serverInfo':
                self.server_info = msg
            elif msg.get('op') == 'advertise':
                for channel in msg['channels']:
                    self.channels[channel['id']] = channel
            elif msg.get('op') == 'unadvertise':
                for cid in msg['channelIds']:
                    self.channels.pop(cid, None)
            return
        if frame[0] == MESSAGE_DATA:
            sub, log_time = struct.unpack_from('<IQ', frame, 1)
            channel = self.subscriptions.get(sub)
            self.messages.setdefault(channel, []).append((log_time, bytes(frame[13:])))

    def subscribe(self, *topics: str):
        subs = []
        for topic in topics:
            channel = self.by_topic(topic)['id']
            sub = len(self.subscriptions) + 1
            self.subscriptions[sub] = channel
            subs.append({'id': sub, 'channelId': channel})
        self.ws.send(json.dumps({'op': 'subscribe', 'subscriptions': subs}))

    def received(self, topic: str) -> list:
        return self.messages.get(self.by_topic(topic)['id'], [])

    def close(self):
        self.ws.close()


def main(argv=None) -> int:
    """A client process: ``foxglove_client.py PORT [--stall] [TOPIC ...]``.

    Subscribes to the topics (all advertised ones with none given), prints ``ready`` once
    subscribed, then reads (``--stall``: never reads again) until its standard input
    closes; prints one JSON line ``{topic: [[log time ns, payload hex], ...]}`` (empty when
    stalled) and exits.
    """
    import argparse
    import sys
    parser = argparse.ArgumentParser()
    parser.add_argument('port', type=int)
    parser.add_argument('topics', nargs='*')
    parser.add_argument('--stall', action='store_true')
    parser.add_argument('--expect', type=int, default=1, help='channels to wait for')
    args = parser.parse_intermixed_args(argv)
    client = FoxgloveClient(args.port)
    if not client.pump_until(lambda: len(client.channels) >= args.expect, 20):
        print(json.dumps({'error': f'{len(client.channels)} channels advertised'}), flush=True)
        return 1
    topics = args.topics or [c['topic'] for c in client.channels.values()]
    client.subscribe(*topics)
    print('ready', flush=True)
    stop = threading.Event()

    def wait_for_eof():
        sys.stdin.read()
        stop.set()
    threading.Thread(target=wait_for_eof, daemon=True).start()
    while not stop.is_set():
        if args.stall:
            stop.wait(0.1)
        else:
            client.pump(0.05)
    out = {} if args.stall else {t: [[lt, data.hex()] for lt, data in client.received(t)]
                                 for t in topics}
    print(json.dumps(out), flush=True)
    client.close()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
