// What the live view's node tests share (tests/live): the real waymark-server with --live, tokens,
// replays through the real CLI, a small JSON Schema check, the Foxglove client over `ws`, PGM
// and PNG readers. No test framework: each test file is a script that exits non-zero on failure
// (registered with CTest in tests/live/CMakeLists.txt).
"use strict";
const assert = require("node:assert/strict");
const { spawn, spawnSync } = require("node:child_process");
const fs = require("node:fs");
const os = require("node:os");
const path = require("node:path");
const zlib = require("node:zlib");
const WebSocket = require("ws");
const { FoxgloveClient } = require("@foxglove/ws-protocol");

const args = Object.fromEntries(
  process.argv.slice(2).map((a) => a.replace(/^--/, "").split(/=(.*)/s).slice(0, 2)));
const BIN = args.bin || path.resolve(__dirname, "../../build/bin");
const SHARED = args.shared || path.resolve(__dirname, "../../../shared");
const SERVER = path.join(BIN, "waymark-server");
const CLI = path.join(BIN, "waymark");

function tempDir(name) {
  return fs.mkdtempSync(path.join(os.tmpdir(), `waymark-live-${name}-`));
}

function log(...what) {
  console.log(`[${new Date().toISOString().slice(11, 23)}]`, ...what);
}

// waymark-server on free ports; resolves once it listens, with its gRPC and live addresses.
async function startServer(dir, extra = []) {
  const db = path.join(dir, "waymark.db");
  const child = spawn(SERVER, ["--listen", "127.0.0.1:0", "--db", db, "--live", "0", ...extra], {
    stdio: ["ignore", "pipe", "pipe"],
  });
  let stderr = "";
  let stdout = "";
  const ready = new Promise((resolve, reject) => {
    const check = () => {
      const grpc = stdout.match(/listening on (\S+)/);
      const live = stderr.match(/live view on http:\/\/([^/\s]+)\//);
      if (grpc && live) resolve({ grpc: grpc[1], live: live[1] });
    };
    child.stdout.on("data", (d) => { stdout += d; check(); });
    child.stderr.on("data", (d) => { stderr += d; check(); });
    child.on("exit", (code) => reject(new Error(`waymark-server exited ${code}:\n${stderr}`)));
  });
  const addresses = await ready;
  child.removeAllListeners("exit");
  return {
    ...addresses, db, child,
    stderr: () => stderr,
    stop: () => new Promise((resolve) => {
      if (child.exitCode !== null) return resolve(child.exitCode);
      child.on("exit", (code) => resolve(code));
      child.kill("SIGTERM");
    }),
  };
}

// A token from the server's own admin command (run on its database while it serves: SQLite).
function createToken(db, name, role) {
  const r = spawnSync(SERVER, ["--db", db, "token", "create", name, "--role", role], { encoding: "utf8" });
  assert.equal(r.status, 0, `token create ${name} --role ${role}: ${r.stderr}`);
  return r.stdout.trim();
}

// `waymark ARGS` as a child process (resolves with its exit code and output).
function runCli(server, argv, { token, cwd } = {}) {
  const env = { ...process.env, WAYMARK_SERVER: server.grpc };
  if (token) env.WAYMARK_TOKEN = token;
  const child = spawn(CLI, argv, { env, cwd, stdio: ["ignore", "pipe", "pipe"] });
  let out = "";
  child.stdout.on("data", (d) => { out += d; });
  child.stderr.on("data", (d) => { out += d; });
  const done = new Promise((resolve) => child.on("exit", (code, signal) => resolve({ code, signal, out })));
  return { child, done, output: () => out };
}

// A Foxglove client we did not write (@foxglove/ws-protocol) over `ws`, with every advertised
// channel and every message kept by topic.
function connectFoxglove(url, subprotocol, options = {}) {
  const ws = new WebSocket(url, [subprotocol], options);
  const client = new FoxgloveClient({ ws });
  const state = {
    ws, client, channels: new Map(), byTopic: new Map(), subscriptions: new Map(),
    messages: new Map(), serverInfo: null, statuses: [], unadvertised: [], closed: null,
  };
  state.opened = new Promise((resolve, reject) => {
    client.on("open", resolve);
    ws.on("unexpected-response", (req, res) => reject(new Error(`HTTP ${res.statusCode}`)));
    client.on("error", (e) => reject(e));
    client.on("close", (e) => reject(new Error(`closed ${e.code}`)));
  });
  client.on("serverInfo", (info) => { state.serverInfo = info; });
  client.on("status", (s) => state.statuses.push(s));
  client.on("close", (e) => { state.closed = e; });
  client.on("advertise", (channels) => {
    for (const c of channels) { state.channels.set(c.id, c); state.byTopic.set(c.topic, c); }
  });
  client.on("unadvertise", (ids) => {
    for (const id of ids) {
      const c = state.channels.get(id);
      if (c) { state.byTopic.delete(c.topic); state.unadvertised.push(c.topic); }
      state.channels.delete(id);
    }
  });
  client.on("message", ({ subscriptionId, timestamp, data }) => {
    const channel = state.subscriptions.get(subscriptionId);
    if (!channel) return;
    const text = new TextDecoder().decode(data);
    if (!state.messages.has(channel.topic)) state.messages.set(channel.topic, []);
    state.messages.get(channel.topic).push({ timestamp, text, channel });
  });
  state.subscribe = (topic) => {
    const channel = state.byTopic.get(topic);
    assert.ok(channel, `no channel ${topic}`);
    const id = client.subscribe(channel.id);
    state.subscriptions.set(id, channel);
    return id;
  };
  state.last = (topic) => {
    const list = state.messages.get(topic);
    return list && list.length ? list[list.length - 1] : null;
  };
  state.count = (topic) => (state.messages.get(topic) || []).length;
  state.close = () => ws.close();
  return state;
}

async function waitFor(what, predicate, seconds = 60) {
  const deadline = Date.now() + seconds * 1000;
  while (Date.now() < deadline) {
    const value = await predicate();
    if (value) return value;
    await new Promise((r) => setTimeout(r, 100));
  }
  throw new Error(`timed out after ${seconds} s waiting for ${what}`);
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// A JSON Schema check of the subset the live view's schemas and foxglove's use: type, properties,
// required, items, minimum, maximum, const, oneOf. Returns the first violation, or null.
function schemaViolation(schema, value, where = "$") {
  if (schema.oneOf) {
    if (!schema.oneOf.some((s) => schemaViolation(s, value, where) === null)) return `${where}: matches no oneOf`;
  }
  if (schema.const !== undefined && value !== schema.const) return `${where}: not ${schema.const}`;
  const type = schema.type;
  const typeOk = {
    object: () => value !== null && typeof value === "object" && !Array.isArray(value),
    array: () => Array.isArray(value),
    string: () => typeof value === "string",
    number: () => typeof value === "number" && Number.isFinite(value),
    integer: () => Number.isInteger(value),
    boolean: () => typeof value === "boolean",
  };
  if (type && !typeOk[type]()) return `${where}: expected ${type}, got ${JSON.stringify(value)?.slice(0, 40)}`;
  if (schema.minimum !== undefined && value < schema.minimum) return `${where}: below ${schema.minimum}`;
  if (schema.maximum !== undefined && value > schema.maximum) return `${where}: above ${schema.maximum}`;
  if (type === "string" && schema.contentEncoding === "base64" && !/^[A-Za-z0-9+/]*={0,2}$/.test(value)) {
    return `${where}: not base64`;
  }
  if (type === "object") {
    for (const key of schema.required || []) if (!(key in value)) return `${where}: missing ${key}`;
    for (const [key, sub] of Object.entries(schema.properties || {})) {
      if (key in value) {
        const v = schemaViolation(sub, value[key], `${where}.${key}`);
        if (v) return v;
      }
    }
  }
  if (type === "array" && schema.items) {
    for (let i = 0; i < value.length; ++i) {
      const v = schemaViolation(schema.items, value[i], `${where}[${i}]`);
      if (v) return v;
    }
  }
  return null;
}

// A binary PGM (P5) as {width, height, pixels}.
function readPgm(file) {
  const buf = fs.readFileSync(file);
  let pos = 0;
  const token = () => {
    for (;;) {
      while (/\s/.test(String.fromCharCode(buf[pos]))) ++pos;
      if (buf[pos] === 0x23) { while (buf[pos] !== 0x0a) ++pos; continue; }
      break;
    }
    const start = pos;
    while (!/\s/.test(String.fromCharCode(buf[pos]))) ++pos;
    return buf.slice(start, pos).toString();
  };
  assert.equal(token(), "P5");
  const width = +token(), height = +token(), max = +token();
  assert.ok(max < 256);
  return { width, height, pixels: buf.slice(pos + 1, pos + 1 + width * height) };
}

// An RGB(A) 8-bit PNG as {width, height, channels, data} (what headless Chromium writes).
function readPng(file) {
  const buf = fs.readFileSync(file);
  let pos = 8;
  let width = 0, height = 0, colorType = 0;
  const idat = [];
  while (pos < buf.length) {
    const length = buf.readUInt32BE(pos);
    const type = buf.toString("latin1", pos + 4, pos + 8);
    const body = buf.slice(pos + 8, pos + 8 + length);
    if (type === "IHDR") {
      width = body.readUInt32BE(0); height = body.readUInt32BE(4);
      assert.equal(body[8], 8, "8-bit PNG");
      colorType = body[9];
      assert.equal(body[12], 0, "not interlaced");
    } else if (type === "IDAT") idat.push(body);
    pos += 12 + length;
  }
  const channels = { 2: 3, 6: 4 }[colorType];
  assert.ok(channels, `PNG colour type ${colorType}`);
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const stride = width * channels;
  const data = Buffer.alloc(height * stride);
  for (let y = 0; y < height; ++y) {
    const filter = raw[y * (stride + 1)];
    for (let x = 0; x < stride; ++x) {
      const v = raw[y * (stride + 1) + 1 + x];
      const a = x >= channels ? data[y * stride + x - channels] : 0;
      const b = y > 0 ? data[(y - 1) * stride + x] : 0;
      const c = x >= channels && y > 0 ? data[(y - 1) * stride + x - channels] : 0;
      let p = 0;
      if (filter === 1) p = a; else if (filter === 2) p = b; else if (filter === 3) p = (a + b) >> 1;
      else if (filter === 4) { const q = a + b - c, pa = Math.abs(q - a), pb = Math.abs(q - b), pc = Math.abs(q - c); p = pa <= pb && pa <= pc ? a : pb <= pc ? b : c; }
      data[y * stride + x] = (v + p) & 0xff;
    }
  }
  return { width, height, channels, data };
}

// Runs `body`, exits 0 on success and 1 (with the error) on failure, stopping what it started.
function main(body) {
  const cleanups = [];
  const t = { cleanup: (f) => cleanups.push(f) };
  body(t).then(
    async () => { for (const f of cleanups.reverse()) await f(); log("PASS"); process.exit(0); },
    async (e) => { console.error("FAIL:", e && e.stack ? e.stack : e); for (const f of cleanups.reverse()) { try { await f(); } catch {} } process.exit(1); });
}

module.exports = {
  args, BIN, SHARED, tempDir, log, startServer, createToken, runCli, connectFoxglove, waitFor,
  sleep, schemaViolation, readPgm, readPng, main,
};
