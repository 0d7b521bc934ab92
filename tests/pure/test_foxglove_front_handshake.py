"""The front's handshake renaming (analyzer/listeners/foxglove_front.py), on
requests and answers written here as RFC 6455 gives them."""

from analyzer.listeners.foxglove_front import renamed_answer, renamed_request

REQUEST = ("GET / HTTP/1.1\r\nHost: 127.0.0.1:8765\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
           "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n{protocol}\r\n")
ANSWER = ("HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
          "Sec-WebSocket-Accept: s3pPLMBiTxaQ9kYGzzhZRbK+xOo=\r\n{protocol}\r\n")


def head(template: str, protocol: str) -> bytes:
    return template.format(protocol=protocol).encode()


def test_the_former_name_alone_is_offered_as_the_new_one():
    renamed, did = renamed_request(head(REQUEST, "Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n"))
    assert did and renamed == head(REQUEST, "Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n")
    # header names are case-insensitive (RFC 7230), and offers are a comma-separated list
    renamed, did = renamed_request(head(REQUEST, "sec-websocket-protocol: other, foxglove.websocket.v1\r\n"))
    assert did and renamed == head(REQUEST, "sec-websocket-protocol: foxglove.sdk.v1\r\n")


def test_other_requests_pass_unchanged():
    for protocol in ("Sec-WebSocket-Protocol: foxglove.sdk.v1, foxglove.websocket.v1\r\n",
                     "Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n",
                     "Sec-WebSocket-Protocol: mqtt\r\n", ""):
        request = head(REQUEST, protocol)
        assert renamed_request(request) == (request, False)


def test_the_answer_names_what_the_client_asked_for():
    answer = head(ANSWER, "Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n")
    # the key and its accept value stay: the client's check of the handshake holds
    assert renamed_answer(answer) == head(ANSWER, "Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n")
    refused = b"HTTP/1.1 400 Bad Request\r\ncontent-length: 0\r\n\r\n"
    assert renamed_answer(refused) == refused
