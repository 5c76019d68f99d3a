"use strict";
// The live page's window of the run, kept from the view's stream: the first
// event holds the whole window ("reset"), the next ones only the columns
// completed since, which are appended and the window trimmed to its length;
// the zoom and the loop histograms are kept until new ones come.
// Loaded by the shared worker (one stream for all tabs of a browser) and by
// the page itself where a browser has no shared workers.
const LIVE_SERIES = ["drive", "measured", "observer", "open_loop", "residual"];

class LiveWindow {
  constructor() { this.d = null; }

  // The zoom comes as a start and a step where the drive's clock is a grid.
  static zoomTimes(z) {
    return z.t || z.y.map((_, i) => z.t0 + i * z.dt);
  }

  apply(e) {
    if (e.reset || !this.d) {
      const held = this.d && this.d.histograms;  // sent again only when they change
      this.d = e;
      if (!e.histograms && held) this.d.histograms = held;
    } else {
      const from = e.t_end - e.window_s;
      for (const name of LIVE_SERIES) {
        const held = this.d[name], added = e[name];
        let keep = 0;
        while (keep < held.t.length && held.t[keep] < from) keep += 1;
        held.t = held.t.slice(keep).concat(added.t);
        held.y = held.y.slice(keep).concat(added.y);
      }
      for (const key of ["t_end", "window_s", "column_s", "status", "pages"]) this.d[key] = e[key];
      if (e.zoom) this.d.zoom = e.zoom;
      if (e.histograms) this.d.histograms = e.histograms;
    }
    if (this.d.zoom && !this.d.zoom.t) this.d.zoom = { t: LiveWindow.zoomTimes(this.d.zoom), y: this.d.zoom.y };
    return this.d;
  }
}
