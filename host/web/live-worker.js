"use strict";
// One stream for every live tab of this browser: a browser keeps at most six
// connections to a host, and a stream per tab would leave none for Stop and
// E-stop. Each tab gets the whole window when it connects, then every update.
importScripts("/live-window.js");

const token = new URL(self.location.href).searchParams.get("token");
const live = new LiveWindow();
const ports = new Set();
const source = new EventSource(token ? `/api/live?token=${encodeURIComponent(token)}` : "/api/live");
source.onmessage = e => {
  const d = live.apply(JSON.parse(e.data));
  for (const port of ports) port.postMessage(d);
};
self.onconnect = e => {
  const port = e.ports[0];
  ports.add(port);
  port.onmessage = m => { if (m.data === "bye") ports.delete(port); };
  port.start();
  if (live.d) port.postMessage(live.d);
};
