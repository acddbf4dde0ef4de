// The live view's own page in a real browser (issue 37): headless Chromium (Debian's chromium,
// driven over the DevTools protocol) loads http://LIVE/?token=VIEWER while a CARMEN log replays
// through the real server, and two screenshots are saved in which the map has grown: the second
// has more drawn map pixels (free white or occupied dark) than the first. The page is drawn at a
// fixed scale (?zoom=) so that pixels compare. `--keep DIR` keeps the screenshots (the README's
// picture comes from one, docs/images/live-view.png).
"use strict";
const assert = require("node:assert/strict");
const fs = require("node:fs");
const path = require("node:path");
const S = require("./live_support.cjs");
const chromium = require("./chromium.cjs");

const LOG = path.join(S.SHARED, "data/laser/aces/aces.clf.bz2");

// Map pixels of a screenshot right of the side panel (280 px wide): grey pixels lighter than the
// unknown (free, up to white) or dark (occupied); the unknown and the background are 205, the scan,
// the trajectory and the robot are coloured.
function drawnMapPixels(png, xFrom) {
  let n = 0;
  for (let y = 0; y < png.height; ++y) {
    for (let x = xFrom; x < png.width; ++x) {
      const o = (y * png.width + x) * png.channels;
      const r = png.data[o], g = png.data[o + 1], b = png.data[o + 2];
      if (r === g && g === b && (r > 215 || r < 100)) ++n;
    }
  }
  return n;
}

S.main(async (t) => {
  const dir = S.args.keep || S.tempDir("page");
  fs.mkdirSync(dir, { recursive: true });
  const server = await S.startServer(S.tempDir("page-db"), ["--live-grid-resolution", "0.1"]);
  t.cleanup(() => server.stop());
  const viewer = S.createToken(server.db, "screen", "viewer");
  const robot = S.createToken(server.db, "replay", "robot");
  const browser = await chromium.launch(S.tempDir("chromium"), { width: 1000, height: 700 });
  t.cleanup(() => browser.close());

  const replay = S.runCli(server, ["slam", "replay", LOG, "--out", path.join(dir, "replay"), "--name", "aces"], { token: robot });
  t.cleanup(() => { if (replay.child.exitCode === null) { replay.child.kill("SIGCONT"); replay.child.kill("SIGKILL"); } });
  const page = await browser.open(`http://${server.live}/?token=${viewer}&zoom=6`);
  const live = () => page.evaluate("JSON.stringify(window.waymarkLive || null)").then((v) => JSON.parse(v));

  // A first picture early in the replay (the robot paused while it is taken), a second later.
  const shots = [];
  for (const grids of [1, 4]) {
    await S.waitFor(`the page's grid #${grids}`, async () => ((await live()) || {}).grids >= grids, 120);
    replay.child.kill("SIGSTOP");
    let last = -1;
    await S.waitFor("the page to settle", async () => {
      const now = (await live()).grids;
      const settled = now === last;
      last = now;
      if (!settled) await S.sleep(2500);
      return settled;
    }, 60);
    const file = path.join(dir, `live-view-${shots.length + 1}.png`);
    await page.screenshot(file);
    const state = await live();
    const png = S.readPng(file);
    shots.push({ file, state, pixels: drawnMapPixels(png, 281) });
    S.log(`${file}: ${JSON.stringify(state)}, ${shots[shots.length - 1].pixels} drawn map pixels`);
    replay.child.kill("SIGCONT");
  }
  assert.ok(shots[0].state.session, "the page chose the session");
  assert.ok(shots[0].pixels > 500, "the first picture shows a map");
  assert.ok(shots[1].state.drawnCells > shots[0].state.drawnCells, "the grid the page drew has grown");
  assert.ok(shots[1].pixels > 1.2 * shots[0].pixels, "the map drawn has grown between the pictures");
  const done = await replay.done;
  assert.ok(done.code === 0 || done.code === 3, `replay: ${done.out}`);
});
