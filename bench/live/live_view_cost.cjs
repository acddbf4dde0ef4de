// What the live view costs the robots (issue 37, docs/live-view.md "Cost"): `waymark bench load`
// with 20 robots against one waymark-server --live, with 0, 1 and 5 viewers that subscribe to
// every channel of every session (the worst case: Foxglove with all topics on), interleaved
// rounds, medians per viewer count: the server's CPU and the per-scan latency (StreamSensorData
// p50/p99 as bench load reports it), as ratios against 0 viewers. Then the memory a viewer keeps:
// 5 viewers that subscribe to everything and stop reading (not dropped: --live-stall-seconds
// 3600), the server's RSS against the 0-viewer rounds, and what /stats says waits for them.
//
//   node bench/live/live_view_cost.cjs [--rounds=3] [--duration=20] [--robots=20]
// (NODE_PATH=tests/js/node_modules; build/bin's binaries; prints a Markdown table.)
"use strict";
const path = require("node:path");
const S = require("../../tests/live/live_support.cjs");

const ROUNDS = +(S.args.rounds || 3);
const DURATION = +(S.args.duration || 20);
const ROBOTS = +(S.args.robots || 20);

function viewer(server, slow) {
  const v = S.connectFoxglove(`ws://${server.live}/`, "foxglove.websocket.v1");
  v.received = 0;
  v.client.on("advertise", (channels) => {
    for (const c of channels) v.subscribe(c.topic);
  });
  v.client.on("message", () => { ++v.received; });
  if (slow) v.client.on("message", () => { if (v.received === 1) v.ws.pause(); });
  return v;
}

async function load(server) {
  const run = await S.runCli(server, ["bench", "load", "--robots", String(ROBOTS), "--duration", String(DURATION),
                                      "--server-pid", String(server.child.pid)]).done;
  if (run.code !== 0) throw new Error(`bench load: ${run.out}`);
  const row = run.out.match(/StreamSensorData\s+(\d+)\s+[\d.]+\s+(\d+)\s+([\d.]+)\s+([\d.]+)/);
  const cpu = run.out.match(/CPU ([\d.]+) s \(([\d.]+) cores\)/);
  const rss = run.out.match(/RSS ([\d.]+) MiB at start, ([\d.]+) peak, ([\d.]+) at end/);
  if (!row || !cpu || !rss) throw new Error(`unexpected bench load output:\n${run.out}`);
  return { scans: +row[2], p50: +row[3], p99: +row[4], cpu: +cpu[1], cores: +cpu[2], rssPeak: +rss[2], rssEnd: +rss[3] };
}

const median = (xs) => { const s = [...xs].sort((a, b) => a - b); const m = s.length >> 1; return s.length % 2 ? s[m] : (s[m - 1] + s[m]) / 2; };

S.main(async (t) => {
  const server = await S.startServer(S.tempDir("cost"), ["--insecure-dev", "--live-stall-seconds", "3600"]);
  t.cleanup(() => server.stop());
  const results = { 0: [], 1: [], 5: [] };
  for (let round = 0; round < ROUNDS; ++round) {
    for (const n of round % 2 ? [5, 1, 0] : [0, 1, 5]) {
      const viewers = Array.from({ length: n }, () => viewer(server, false));
      await Promise.all(viewers.map((v) => v.opened));
      const r = await load(server);
      r.received = viewers.reduce((sum, v) => sum + v.received, 0);
      viewers.forEach((v) => v.close());
      results[n].push(r);
      S.log(`round ${round + 1}, ${n} viewers: ${JSON.stringify(r)}`);
      await S.sleep(1500);
    }
  }
  const base = { cpu: median(results[0].map((r) => r.cpu)), p50: median(results[0].map((r) => r.p50)), p99: median(results[0].map((r) => r.p99)) };
  console.log(`\n${ROBOTS} robots, ${DURATION} s per round, ${ROUNDS} rounds per viewer count (medians; ratio to 0 viewers)\n`);
  console.log("| viewers | server CPU (s) | ratio | scan p50 (ms) | ratio | scan p99 (ms) | ratio | messages to viewers |");
  console.log("|---|---|---|---|---|---|---|---|");
  for (const n of [0, 1, 5]) {
    const cpu = median(results[n].map((r) => r.cpu)), p50 = median(results[n].map((r) => r.p50)), p99 = median(results[n].map((r) => r.p99));
    const got = median(results[n].map((r) => r.received));
    console.log(`| ${n} | ${cpu.toFixed(2)} | ${(cpu / base.cpu).toFixed(2)} | ${p50.toFixed(2)} | ${(p50 / base.p50).toFixed(2)} | ${p99.toFixed(2)} | ${(p99 / base.p99).toFixed(2)} | ${got} |`);
  }

  // Memory: 5 viewers that take one message and then stop reading.
  const slow = Array.from({ length: 5 }, () => viewer(server, true));
  await Promise.all(slow.map((v) => v.opened));
  const r = await load(server);
  const stats = await (await fetch(`http://${server.live}/stats`)).json();
  const pending = stats.viewers.map((v) => v.pending_bytes);
  const skipped = stats.viewers.map((v) => v.skipped);
  slow.forEach((v) => v.close());
  const rss0 = median(results[0].map((x) => x.rssPeak));
  console.log(`\nmemory: server RSS peak ${r.rssPeak.toFixed(1)} MiB with 5 stalled viewers vs ${rss0.toFixed(1)} MiB (median, 0 viewers): ` +
              `${((r.rssPeak - rss0) / 5).toFixed(2)} MiB per viewer; /stats pending bytes per viewer ${JSON.stringify(pending)} ` +
              `(shared payloads), frames skipped ${JSON.stringify(skipped)}; scan p50 ${r.p50} ms, CPU ${r.cpu} s`);
});
