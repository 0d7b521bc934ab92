// A Foxglove WebSocket client built on @foxglove/ws-protocol's FoxgloveClient, the
// library of older Lichtblick releases and of other clients that offer the
// protocol's former name (tests/interop/test_foxglove_clients.py).
//
//   node live.mjs URL [SUBPROTOCOL]
//
// It offers SUBPROTOCOL alone (default: the library's own, foxglove.websocket.v1),
// subscribes to every channel as it is advertised, and prints one JSON object a
// line as things come, until the server closes the connection:
//   {"op":"open","subprotocol":...}             the name the server chose
//   {"op":"advertise","channel":{...}}          a channel as advertised
//   {"op":"synced","topics":[...]}              the server has taken every subscription so far
//   {"op":"message","topic":...,"logTime":"ns","data":"base64"}
//   {"op":"status","status":{...}}
//   {"op":"close","code":N}
// An error (a refused handshake) goes to standard error, exit 1.
import wsProtocol from "@foxglove/ws-protocol";   // CommonJS: its exports are the default's
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;

const [url, subprotocol = FoxgloveClient.SUPPORTED_SUBPROTOCOL] = process.argv.slice(2);
// the answer to a request for parameters, a capability the server lacks: it answers
// requests in turn, so this answer says it has handled every subscription sent before
const PARAMETERS = "does not support parameters";
// foxglove-sdk 0.30 may refuse a subscription that comes right after a channel's
// advertisement (tests/integration/test_foxglove_live.py, Client._control): again
const REFUSED = /^Unknown channel ID: (\d+)$/;

const ws = new WebSocket(url, [subprotocol]);
const client = new FoxgloveClient({ ws });
const channels = new Map();       // channel id -> channel
const subscriptions = new Map();  // subscription id -> topic
let syncing = false;              // a request for parameters is out
let again = false;                // something changed meanwhile: ask once more

const say = (obj) => process.stdout.write(JSON.stringify(obj) + "\n");

function subscribe(channelId) {
  subscriptions.set(client.subscribe(channelId), channels.get(channelId).topic);
}

function sync() {
  if (syncing) {
    again = true;
    return;
  }
  syncing = true;
  again = false;
  client.getParameters([], "sync");
}

client.on("open", () => say({ op: "open", subprotocol: ws.protocol }));
client.on("advertise", (advertised) => {
  for (const channel of advertised) {
    channels.set(channel.id, channel);
    say({ op: "advertise", channel });
    subscribe(channel.id);
  }
  sync();
});
client.on("status", (status) => {
  say({ op: "status", status });
  const refused = REFUSED.exec(status.message);
  if (refused && channels.has(Number(refused[1]))) {
    subscribe(Number(refused[1]));
    again = true;
  } else if (status.message.includes(PARAMETERS)) {
    syncing = false;
    if (again) {
      sync();
    } else {
      say({ op: "synced", topics: [...new Set(subscriptions.values())] });
    }
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  say({
    op: "message",
    topic: subscriptions.get(subscriptionId),
    logTime: timestamp.toString(),
    data: Buffer.from(data.buffer, data.byteOffset, data.byteLength).toString("base64"),
  });
});
client.on("error", (error) => {
  process.stderr.write(`live.mjs: ${error?.message ?? error}\n`);
  process.exitCode = 1;
});
client.on("close", (event) => say({ op: "close", code: event.code }));
