// The live view against a Foxglove client we did not write (issue 37): @foxglove/ws-protocol's
// FoxgloveClient over `ws`, on the real waymark-server with authentication on, while a CARMEN log
// replays through the real CLI.
//   - each subprotocol name is accepted and echoed: foxglove.websocket.v1, foxglove.sdk.v1;
//   - no token, a robot's token and a bad token are refused (the page too); a viewer's token, as
//     ?token= or as an Authorization header, is accepted;
//   - the session's channels are advertised while it runs and withdrawn when it closes;
//   - every message received decodes by the schema its channel advertised, and the foxglove.*
//     ones by foxglove's own published schemas (@foxglove/schemas);
//   - the replay is paused (SIGSTOP) and the last grid sent equals GetOccupancyGrid's answer at the
//     same resolution (`waymark slam map` with the viewer's token: map.yaml and map.pgm): size,
//     resolution, origin and every cell.
"use strict";
const assert = require("node:assert/strict");
const fs = require("node:fs");
const path = require("node:path");
const foxgloveSchemas = require("@foxglove/schemas/jsonschema");
const S = require("./live_support.cjs");

const LOG = path.join(S.SHARED, "data/laser/aces/aces.clf.bz2");
const RESOLUTION = 0.1;  // the server's default --live-grid-resolution

async function expectRefused(url, protocol, options, status) {
  const fox = S.connectFoxglove(url, protocol, options);
  await assert.rejects(fox.opened, (e) => {
    assert.match(String(e.message), new RegExp(`HTTP ${status}`));
    return true;
  });
}

async function httpStatus(url, headers = {}) {
  const res = await fetch(url, { headers });
  return { status: res.status, body: await res.text() };
}

S.main(async (t) => {
  assert.ok(fs.existsSync(LOG), `missing ${LOG} (../shared)`);
  const dir = S.tempDir("view");
  const server = await S.startServer(dir, ["--live-grid-resolution", String(RESOLUTION)]);
  t.cleanup(() => server.stop());
  const viewer = S.createToken(server.db, "wall-screen", "viewer");
  const robot = S.createToken(server.db, "replay", "robot");  // `slam replay`'s robot id
  const base = `ws://${server.live}/`;
  S.log("server", server.grpc, "live", server.live);

  // Auth: the WebSocket upgrade and the page.
  await expectRefused(base, "foxglove.websocket.v1", {}, 401);
  await expectRefused(`${base}?token=wm_${"0".repeat(64)}`, "foxglove.websocket.v1", {}, 401);
  await expectRefused(`${base}?token=${robot}`, "foxglove.sdk.v1", {}, 403);
  await expectRefused(base, "foxglove.sdk.v1", { headers: { Authorization: `Bearer ${robot}` } }, 403);
  assert.equal((await httpStatus(`http://${server.live}/`)).status, 401);
  assert.equal((await httpStatus(`http://${server.live}/?token=${robot}`)).status, 403);
  const page = await httpStatus(`http://${server.live}/?token=${viewer}`);
  assert.equal(page.status, 200);
  assert.match(page.body, /<canvas/);
  assert.equal((await httpStatus(`http://${server.live}/stats`, { Authorization: `Bearer ${viewer}` })).status, 200);

  // Both subprotocol names, a viewer token each way.
  const a = S.connectFoxglove(`${base}?token=${viewer}`, "foxglove.websocket.v1");
  const b = S.connectFoxglove(base, "foxglove.sdk.v1", { headers: { Authorization: `Bearer ${viewer}` } });
  t.cleanup(() => { a.close(); b.close(); });
  await a.opened;
  await b.opened;
  assert.equal(a.ws.protocol, "foxglove.websocket.v1");
  assert.equal(b.ws.protocol, "foxglove.sdk.v1");
  for (const c of [a, b]) {
    await S.waitFor("serverInfo and the server-wide channels", () => c.serverInfo && c.byTopic.has("/sessions"));
    assert.equal(c.serverInfo.op, "serverInfo");
    c.subscribe("/sessions");
  }

  // A replay; its session's channels appear.
  const out = path.join(dir, "replay");
  const replay = S.runCli(server, ["slam", "replay", LOG, "--out", out, "--resolution", String(RESOLUTION)], { token: robot });
  t.cleanup(() => { if (replay.child.exitCode === null) { replay.child.kill("SIGCONT"); replay.child.kill("SIGKILL"); } });
  const gridTopic = await S.waitFor("a session's grid channel", () =>
    [...a.byTopic.keys()].find((topic) => /^\/sessions\/[0-9a-f]+\/grid$/.test(topic)), 60);
  const prefix = gridTopic.slice(0, -"grid".length);
  const sessionId = prefix.split("/")[2];
  S.log("session", sessionId);
  for (const kind of ["pose", "scan", "grid", "trajectory", "loop_closures", "confidence"]) {
    assert.ok(a.byTopic.has(prefix + kind), `channel ${prefix + kind}`);
  }
  for (const kind of ["grid", "pose", "scan", "trajectory", "confidence", "loop_closures"]) a.subscribe(prefix + kind);
  for (const kind of ["grid", "pose"]) b.subscribe(prefix + kind);

  // The map grows while the log replays.
  await S.waitFor("two grids and poses on both connections", () =>
    a.count(prefix + "grid") >= 2 && b.count(prefix + "grid") >= 1 && a.count(prefix + "pose") >= 3 && b.count(prefix + "pose") >= 3, 120);

  // Pause the robot: the session stays open, nothing new arrives; the last grid is rendered from
  // the same map GetOccupancyGrid reads.
  replay.child.kill("SIGSTOP");
  let seen = a.count(prefix + "grid");
  let quietSince = Date.now();
  await S.waitFor("the grid channel to go quiet (no change for 3 s)", () => {
    const n = a.count(prefix + "grid");
    if (n !== seen) { seen = n; quietSince = Date.now(); }
    return Date.now() - quietSince > 3000;
  }, 60);
  const mapDir = path.join(dir, "map");
  const map = await S.runCli(server, ["slam", "map", sessionId, "--out", mapDir, "--resolution", String(RESOLUTION)], { token: viewer }).done;
  assert.equal(map.code, 0, `slam map with a viewer token: ${map.out}`);
  const grid = JSON.parse(a.last(prefix + "grid").text);
  const yaml = fs.readFileSync(path.join(mapDir, "map.yaml"), "utf8");
  const resolution = +yaml.match(/resolution:\s*([-\d.e]+)/)[1];
  const origin = yaml.match(/origin:\s*\[\s*([-\d.e]+),\s*([-\d.e]+)/).slice(1, 3).map(Number);
  const pgm = S.readPgm(path.join(mapDir, "map.pgm"));
  assert.ok(Math.abs(grid.cell_size.x - resolution) < 1e-9 && Math.abs(grid.cell_size.y - resolution) < 1e-9,
    `resolution ${grid.cell_size.x} vs ${resolution}`);
  assert.ok(Math.abs(grid.pose.position.x - origin[0]) < 1e-6 && Math.abs(grid.pose.position.y - origin[1]) < 1e-6,
    `origin ${JSON.stringify(grid.pose.position)} vs ${origin}`);
  const cells = Buffer.from(grid.data, "base64");
  const rows = cells.length / grid.row_stride;
  assert.equal(grid.column_count, pgm.width, "width");
  assert.equal(rows, pgm.height, "height");
  assert.deepEqual(grid.fields, [{ name: "occupancy", offset: 0, type: 2 }]);
  // map_server's PGM: rows run down, occupied >= 65 black, free <= 19 white, the rest unknown.
  let differ = 0, known = 0;
  for (let row = 0; row < rows; ++row) {
    for (let col = 0; col < grid.column_count; ++col) {
      const cell = cells.readInt8(row * grid.row_stride + col * grid.cell_stride);
      const pixel = cell >= 65 ? 0 : cell >= 0 && cell <= 19 ? 254 : 205;
      if (pixel !== 205) ++known;
      if (pixel !== pgm.pixels[(rows - 1 - row) * pgm.width + col]) ++differ;
    }
  }
  S.log(`grid ${grid.column_count} x ${rows} at ${resolution} m, ${known} known cells, ${differ} differ`);
  assert.ok(known > 1000, "the grid holds a map");
  assert.equal(differ, 0, "every cell as GetOccupancyGrid's");

  // Every message decodes by its advertised schema (and foxglove's own for foxglove.*).
  let checked = 0;
  for (const fox of [a, b]) {
    for (const [topic, list] of fox.messages) {
      const channel = list[0].channel;
      assert.equal(channel.encoding, "json");
      assert.equal(channel.schemaEncoding, "jsonschema");
      const advertised = JSON.parse(channel.schema);
      const official = channel.schemaName.startsWith("foxglove.") ? foxgloveSchemas[channel.schemaName.slice(9)] : null;
      if (channel.schemaName.startsWith("foxglove.")) assert.ok(official, `foxglove publishes ${channel.schemaName}`);
      for (const m of list) {
        const value = JSON.parse(m.text);
        const v = S.schemaViolation(advertised, value) || (official && S.schemaViolation(official, value));
        assert.equal(v, null, `${topic}: ${v}`);
        ++checked;
      }
    }
  }
  S.log(`${checked} messages checked against their schemas`);
  const pose = JSON.parse(a.last(prefix + "pose").text);
  assert.equal(pose.frame_id, "map");
  const scan = JSON.parse(a.last(prefix + "scan").text);
  assert.equal(scan.ranges.length, 180, "one range per beam of the log's 180-beam scans");

  // The robot goes on; when its session closes, the channels are withdrawn.
  replay.child.kill("SIGCONT");
  const done = await replay.done;
  assert.ok(done.code === 0 || done.code === 3, `replay: ${done.out}`);
  await S.waitFor("the session's channels withdrawn", () => a.unadvertised.includes(prefix + "grid") && b.unadvertised.includes(prefix + "pose"), 30);
  assert.ok(!a.byTopic.has(prefix + "pose"));
});
