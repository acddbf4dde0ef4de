// A slow viewer never slows a robot (issue 37): a viewer that subscribes to everything and then
// stops reading (its socket paused) sits beside a normal viewer while a CARMEN log replays at full
// speed. The replay ends with every scan answered, the normal viewer keeps getting poses, and the
// server first skips the slow viewer's frames (newest only per channel) and then drops it
// (--live-stall-seconds). Nothing here measures time: the assertions are on counts and outcomes.
"use strict";
const assert = require("node:assert/strict");
const path = require("node:path");
const S = require("./live_support.cjs");

const LOG = path.join(S.SHARED, "data/laser/aces/aces.clf.bz2");

async function stats(server) {
  return (await fetch(`http://${server.live}/stats`)).json();
}

S.main(async (t) => {
  const dir = S.tempDir("slow");
  // Auth off here (the auth cases are live_view_test's); fine grids make big messages. The stall
  // limit is what a starved machine must not reach for the normal viewer: at 2 s it was reached
  // once on the 2-core machine at load 6 (both viewers dropped); the paused one reaches any limit.
  const server = await S.startServer(dir, ["--insecure-dev", "--live-grid-resolution", "0.03",
                                           "--live-stall-seconds", "6"]);
  t.cleanup(() => server.stop());
  const base = `ws://${server.live}/`;
  const slow = S.connectFoxglove(base, "foxglove.websocket.v1");
  const fast = S.connectFoxglove(base, "foxglove.sdk.v1");
  t.cleanup(() => { slow.close(); fast.close(); });
  await slow.opened;
  await fast.opened;

  const replay = S.runCli(server, ["slam", "replay", LOG, "--out", path.join(dir, "replay")]);
  t.cleanup(() => { if (replay.child.exitCode === null) replay.child.kill("SIGKILL"); });
  const gridTopic = await S.waitFor("the session's channels", () =>
    [...slow.byTopic.keys()].find((topic) => /^\/sessions\/[0-9a-f]+\/grid$/.test(topic)), 60);
  const prefix = gridTopic.slice(0, -"grid".length);
  for (const kind of ["grid", "trajectory", "scan", "pose", "confidence"]) slow.subscribe(prefix + kind);
  fast.subscribe(prefix + "pose");
  await S.waitFor("the slow viewer's first grid", () => slow.count(prefix + "grid") >= 1, 60);
  slow.ws.pause();  // from here on it reads nothing: its TCP window closes, then the server's buffer fills
  const posesBefore = fast.count(prefix + "pose");
  S.log("slow viewer paused after", slow.count(prefix + "grid"), "grids");
  // Its frames are skipped (a newer one replaces the one it has not taken) before it is dropped.
  const skipping = await S.waitFor("the slow viewer's frames skipped", async () => {
    const s = await stats(server);
    return s.viewers.find((v) => v.id === 1 && v.skipped > 0) || (s.dropped_viewers > 0 ? "dropped" : null);
  }, 60);
  assert.notEqual(skipping, "dropped", "frames were skipped before the viewer was dropped");
  S.log("slow viewer while stalled:", JSON.stringify(skipping));

  const done = await replay.done;
  assert.ok(done.code === 0 || done.code === 3, `replay: ${done.out}`);
  const processed = done.out.match(/(\d+) scans processed \((\d+) sent, (\d+) rejected/);
  assert.ok(processed, done.out);
  assert.equal(processed[1], processed[2], "every scan sent was processed");
  assert.equal(processed[3], "0", "no scan rejected");
  S.log(`replay: ${processed[0]}`);
  assert.ok(fast.count(prefix + "pose") > posesBefore, "the normal viewer kept getting poses");

  // The slow viewer: frames skipped while it could not take them, then dropped once something
  // waited for it longer than the stall limit. The kernel's socket buffers may have taken all
  // that the replay sent it (a fast replay on a loaded machine: nothing waited, so nothing
  // stalled); a second session's channel announcements then wait for it, as any new data would.
  const dropped = async () => {
    const s = await stats(server);
    return s.dropped_viewers >= 1 ? s : null;
  };
  if (!(await dropped())) {
    const more = S.runCli(server, ["slam", "replay", LOG, "--scans", "1:300",
                                   "--out", path.join(dir, "replay2")]);
    t.cleanup(() => { if (more.child.exitCode === null) more.child.kill("SIGKILL"); });
    const moreDone = await more.done;
    assert.ok(moreDone.code === 0 || moreDone.code === 3, `second replay: ${moreDone.out}`);
  }
  const after = await S.waitFor("the slow viewer dropped", dropped, 60);
  S.log("stats after the drop:", JSON.stringify(after));
  assert.equal(after.viewers.length, 1, "only the normal viewer is left");
  slow.ws.resume();
  await S.waitFor("the slow viewer's socket closed", () => slow.closed !== null, 30);
  assert.ok(/dropping viewer \d+: it took nothing/.test(server.stderr()), "the drop is logged");
});
