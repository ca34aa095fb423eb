// An independent Foxglove client for cli/tests/it/foxglove.rs: Foxglove's own WebSocket
// protocol client (@foxglove/ws-protocol) subscribes to a live AVACraft view and decodes
// one image and one SceneUpdate with the protobuf schemas the server advertised (as the
// Foxglove app does), then prints what it decoded as one JSON line. With a second argument,
// it also waits for a log line whose name starts with it (e.g. `ava/`: an AVA model call).
"use strict";
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const WebSocket = require("ws");
const protobuf = require("protobufjs");
const { FileDescriptorSet } = require("protobufjs/ext/descriptor");

const url = process.argv[2];
const logPrefix = process.argv[3];
// The subprotocol the client library offers by itself, as Lichtblick does.
const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
const client = new FoxgloveClient({ ws });
const subs = new Map();
const out = { serverInfo: null, channels: [], image: null, scene: null, status: null, log: null };
const fail = (why) => {
  console.error(why);
  process.exit(1);
};
setTimeout(() => fail(`timed out: ${JSON.stringify(out).slice(0, 400)}`), 60000);

client.on("error", (e) => fail(`client error: ${e}`));
client.on("serverInfo", (info) => {
  out.serverInfo = info.name;
});
client.on("advertise", (channels) => {
  // Status last: the server starts playing once it is watched.
  const order = [...channels].sort((a, b) => (a.topic.endsWith("/episode_status") ? 1 : 0) - (b.topic.endsWith("/episode_status") ? 1 : 0));
  for (const ch of order) {
    out.channels.push(ch.topic);
    let type = null;
    if (ch.encoding === "protobuf") {
      const fds = FileDescriptorSet.decode(Buffer.from(ch.schema, "base64"));
      type = protobuf.Root.fromDescriptor(fds).lookupType(ch.schemaName);
    }
    subs.set(client.subscribe(ch.id), { ch, type });
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const sub = subs.get(subscriptionId);
  if (!sub) fail(`message for unknown subscription ${subscriptionId}`);
  const bytes = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  const topic = sub.ch.topic;
  if (topic.endsWith("/screen_image") && !out.image) {
    const m = sub.type.decode(bytes);
    out.image = { schema: sub.ch.schemaName, width: m.width, height: m.height, encoding: m.encoding, step: m.step, bytes: m.data.length, timestamp: String(timestamp) };
  } else if (topic.endsWith("/scene_update") && !out.scene) {
    const m = sub.type.decode(bytes);
    const e = m.entities[0];
    out.scene = { schema: sub.ch.schemaName, entities: m.entities.length, frame: e && e.frameId, id: e && e.id, cylinders: e ? e.cylinders.length : 0, label: e && e.texts[0] && e.texts[0].text };
  } else if (topic.endsWith("/episode_status") && !out.status) {
    out.status = JSON.parse(Buffer.from(bytes).toString("utf8"));
  } else if (topic.endsWith("/log_lines") && logPrefix && !out.log) {
    const m = sub.type.decode(bytes);
    if (m.name.startsWith(logPrefix)) out.log = { schema: sub.ch.schemaName, name: m.name, message: m.message, level: m.level };
  }
  if (out.image && out.scene && out.status && (!logPrefix || out.log)) {
    console.log(JSON.stringify(out));
    ws.close();
    process.exit(0);
  }
});
