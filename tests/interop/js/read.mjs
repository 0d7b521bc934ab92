// read.mjs reads an MCAP file with Foxglove's own TypeScript library (@mcap/core), the one
// the Foxglove app opens files with, and prints what it found as one JSON object: a reader
// we did not write, for tests/interop/test_mcap_core.py.
//
// It reads the file twice, as the app can: by its index (McapIndexedReader: summary, chunk
// indexes, messages in log-time order, metadata by its index) and front to back
// (McapStreamReader: the app's way for a file without a usable index). Both with chunk CRCs
// checked and zstd chunks inflated by the app's own decompressor (@foxglove/wasm-zstd).
// Exit 1, with one line on stderr, when the file does not read.
//
// usage: node read.mjs FILE.mcap
import { open } from "node:fs/promises";
import { createReadStream } from "node:fs";

import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import zstd from "@foxglove/wasm-zstd";

const COLUMNS_TOPIC = "/gimbalscope/columns";
// an Arrow IPC stream's messages each begin with this continuation marker
const ARROW_CONTINUATION = 0xffffffff;

const decompressHandlers = {
  zstd: (buffer, decompressedSize) => zstd.decompress(buffer, Number(decompressedSize)),
};

function fail(message) {
  process.stderr.write(`read.mjs: ${message}\n`);
  process.exit(1);
}

/** What one pass over the file saw; both readers fill the same shape. */
class Seen {
  messages = {};
  encodings = {};
  schemas = {};
  metadata = {};
  columns = [];
  #topics = new Map();

  channel(channel, schema) {
    this.#topics.set(channel.id, channel.topic);
    this.encodings[channel.topic] = channel.messageEncoding;
    this.schemas[channel.topic] = schema ? { name: schema.name, encoding: schema.encoding } : null;
  }

  message(message) {
    const topic = this.#topics.get(message.channelId);
    if (topic === undefined) {
      fail(`message on channel ${message.channelId}, which no channel record declared`);
    }
    this.messages[topic] = (this.messages[topic] ?? 0) + 1;
    if (topic === COLUMNS_TOPIC) {
      const data = message.data;
      const marker = data.byteLength >= 4
        ? new DataView(data.buffer, data.byteOffset, 4).getUint32(0, true) === ARROW_CONTINUATION
        : false;
      this.columns.push({ bytes: data.byteLength, arrow: marker });
    }
  }

  metadataRecord(record) {
    if (record.name in this.metadata) {
      fail(`two metadata records named ${JSON.stringify(record.name)}`);
    }
    this.metadata[record.name] = Object.fromEntries(record.metadata);
  }

  toJSON() {
    return {
      messages: this.messages,
      encodings: this.encodings,
      schemas: this.schemas,
      metadata: this.metadata,
      columns: this.columns,
    };
  }
}

async function readIndexed(path) {
  const handle = await open(path, "r");
  try {
    const readable = {
      size: async () => BigInt((await handle.stat()).size),
      read: async (offset, size) => {
        const buffer = new Uint8Array(Number(size));
        const { bytesRead } = await handle.read(buffer, 0, buffer.byteLength, Number(offset));
        if (bytesRead !== buffer.byteLength) {
          throw new Error(`short read: ${bytesRead} of ${size} bytes at ${offset}`);
        }
        return buffer;
      },
    };
    const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
    const seen = new Seen();
    for (const channel of reader.channelsById.values()) {
      seen.channel(channel, reader.schemasById.get(channel.schemaId));
    }
    let count = 0;
    for await (const message of reader.readMessages({ validateCrcs: true })) {
      seen.message(message);
      count++;
    }
    for await (const record of reader.readMetadata()) {
      seen.metadataRecord(record);
    }
    const stats = reader.statistics;
    const compressions = {};
    for (const chunk of reader.chunkIndexes) {
      compressions[chunk.compression] = (compressions[chunk.compression] ?? 0) + 1;
    }
    return {
      ...seen.toJSON(),
      profile: reader.header.profile,
      library: reader.header.library,
      chunks: reader.chunkIndexes.length,
      chunk_compressions: compressions,
      statistics_message_count: stats ? Number(stats.messageCount) : null,
      read_message_count: count,
    };
  } finally {
    await handle.close();
  }
}

async function readStream(path) {
  const reader = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  const seen = new Seen();
  const schemas = new Map();
  const pending = [];   // channels whose schema record comes later (a schema id of 0 has none)
  let footer = false;
  for await (const data of createReadStream(path, { highWaterMark: 64 * 1024 })) {
    reader.append(new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
    for (let record; (record = reader.nextRecord()); ) {
      switch (record.type) {
        case "Schema":
          schemas.set(record.id, record);
          break;
        case "Channel":
          if (record.schemaId !== 0 && !schemas.has(record.schemaId)) {
            pending.push(record);
          }
          seen.channel(record, schemas.get(record.schemaId));
          break;
        case "Message":
          seen.message(record);
          break;
        case "Metadata":
          seen.metadataRecord(record);
          break;
        case "Footer":
          footer = true;
          break;
        default:
          break;
      }
    }
  }
  if (!reader.done()) {
    fail(`the stream reader stopped ${reader.bytesRemaining()} bytes before the file's end`);
  }
  for (const channel of pending) {
    if (!schemas.has(channel.schemaId)) {
      fail(`channel ${channel.topic} names schema ${channel.schemaId}, which no schema record declared`);
    }
    seen.channel(channel, schemas.get(channel.schemaId));
  }
  return { ...seen.toJSON(), footer };
}

async function main() {
  const args = process.argv.slice(2);
  if (args.length !== 1) {
    fail("usage: node read.mjs FILE.mcap");
  }
  await zstd.isLoaded;
  const path = args[0];
  let indexed;
  let stream;
  try {
    indexed = await readIndexed(path);
  } catch (err) {
    fail(`McapIndexedReader: ${err.message}`);
  }
  try {
    stream = await readStream(path);
  } catch (err) {
    fail(`McapStreamReader: ${err.message}`);
  }
  process.stdout.write(JSON.stringify({ indexed, stream }) + "\n");
}

await main();
