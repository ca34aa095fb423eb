// Takes a picture of Foxglove Studio showing a live AVACraft view:
//   node shot.js ws://127.0.0.1:8765 out.png [seconds to wait, default 30]
// Serves this folder (index.html mounts Foxglove Studio 1.48 from node_modules) with
// docs/foxglove-layout.json as layout.json, opens it in headless Chromium connected to the
// given Foxglove WebSocket URL, waits, and saves a 1600x1000 screenshot.
"use strict";
const http = require("http");
const fs = require("fs");
const path = require("path");
const puppeteer = require("puppeteer-core");

const [url, out, wait] = [process.argv[2], process.argv[3], Number(process.argv[4] || 30)];
if (!url || !out || !(wait >= 0)) {
  console.error("usage: node shot.js ws://HOST:PORT out.png [seconds]");
  process.exit(2);
}
const root = __dirname;
const layout = path.join(root, "../../docs/foxglove-layout.json");
const types = { ".html": "text/html", ".js": "text/javascript", ".json": "application/json", ".wasm": "application/wasm", ".png": "image/png", ".ttf": "font/ttf" };

const server = http.createServer((req, res) => {
  const rel = decodeURIComponent(new URL(req.url, "http://x").pathname).replace(/^\/+/, "");
  const file = rel === "layout.json" ? layout : path.join(root, rel || "index.html");
  if (!file.startsWith(root) && file !== layout) {
    res.writeHead(403).end();
    return;
  }
  fs.readFile(file, (err, body) => {
    if (err) {
      res.writeHead(404).end();
      return;
    }
    res.writeHead(200, { "content-type": types[path.extname(file)] || "application/octet-stream" }).end(body);
  });
});

server.listen(0, "127.0.0.1", async () => {
  const page_url = `http://127.0.0.1:${server.address().port}/index.html?ds=foxglove-websocket&ds.url=${encodeURIComponent(url)}&layoutId=avacraft`;
  const browser = await puppeteer.launch({
    executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
    headless: true,
    // Software WebGL for the 3D panel.
    args: ["--no-sandbox", "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--ignore-gpu-blocklist", "--window-size=1600,1000"],
  });
  try {
    const page = await browser.newPage();
    await page.setViewport({ width: 1600, height: 1000 });
    page.on("pageerror", (e) => console.error("page error:", String(e).slice(0, 300)));
    await page.goto(page_url, { waitUntil: "load" });
    await new Promise((r) => setTimeout(r, wait * 1000));
    // The 3D panel's first-run hint covers its corner.
    await page.evaluate(() => document.querySelectorAll('[aria-label="close"], [data-testid="CloseIcon"]').forEach((b) => (b.closest("button") || b).click()));
    await new Promise((r) => setTimeout(r, 500));
    await page.screenshot({ path: out });
    console.log(`saved ${out}`);
  } finally {
    await browser.close();
    server.close();
  }
});
