// Headless Chromium (Debian's `chromium`) driven over the DevTools protocol with `ws`: open a
// page, evaluate an expression in it, save a screenshot. Enough for tests/live's page test; no
// browser automation package needed.
"use strict";
const { spawn } = require("node:child_process");
const fs = require("node:fs");
const WebSocket = require("ws");

const CHROMIUM = process.env.WAYMARK_CHROMIUM || "/usr/bin/chromium";

async function launch(userDataDir, { width = 1000, height = 700 } = {}) {
  if (!fs.existsSync(CHROMIUM)) throw new Error(`no ${CHROMIUM}: scripts/install-deps.sh installs Debian's chromium`);
  const child = spawn(CHROMIUM, [
    "--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run", "--no-default-browser-check",
    "--remote-debugging-port=0", `--user-data-dir=${userDataDir}`, `--window-size=${width},${height}`,
    "about:blank"], { stdio: ["ignore", "ignore", "pipe"] });
  let stderr = "";
  const endpoint = await new Promise((resolve, reject) => {
    child.stderr.on("data", (d) => {
      stderr += d;
      const m = stderr.match(/DevTools listening on (ws:\/\/\S+)/);
      if (m) resolve(m[1]);
    });
    child.on("exit", (code) => reject(new Error(`chromium exited ${code}: ${stderr}`)));
  });
  child.removeAllListeners("exit");
  const ws = new WebSocket(endpoint, { perMessageDeflate: false });
  await new Promise((resolve, reject) => { ws.on("open", resolve); ws.on("error", reject); });
  let nextId = 1;
  const pending = new Map();
  ws.on("message", (data) => {
    const msg = JSON.parse(data);
    if (msg.id && pending.has(msg.id)) {
      const { resolve, reject } = pending.get(msg.id);
      pending.delete(msg.id);
      if (msg.error) reject(new Error(JSON.stringify(msg.error))); else resolve(msg.result);
    }
  });
  const send = (method, params = {}, sessionId) => new Promise((resolve, reject) => {
    const id = nextId++;
    pending.set(id, { resolve, reject });
    ws.send(JSON.stringify({ id, method, params, ...(sessionId ? { sessionId } : {}) }));
  });
  return {
    async open(url) {
      const { targetId } = await send("Target.createTarget", { url: "about:blank" });
      const { sessionId } = await send("Target.attachToTarget", { targetId, flatten: true });
      await send("Page.enable", {}, sessionId);
      await send("Emulation.setDeviceMetricsOverride", { width, height, deviceScaleFactor: 1, mobile: false }, sessionId);
      await send("Page.navigate", { url }, sessionId);
      return {
        async evaluate(expression) {
          const r = await send("Runtime.evaluate", { expression, returnByValue: true }, sessionId);
          return r.result.value;
        },
        async screenshot(file) {
          const r = await send("Page.captureScreenshot", { format: "png" }, sessionId);
          fs.writeFileSync(file, Buffer.from(r.data, "base64"));
        },
      };
    },
    async close() {
      try { await send("Browser.close"); } catch {}
      ws.close();
      await new Promise((resolve) => { if (child.exitCode !== null) resolve(); else { child.on("exit", resolve); setTimeout(() => { child.kill("SIGKILL"); }, 5000); } });
    },
  };
}

module.exports = { launch };
