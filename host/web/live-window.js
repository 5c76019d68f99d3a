"use strict";
// The live page's window of the run, kept from the view's stream: the first
// event holds the whole window ("reset"), the next ones only the columns
// completed since, which are appended and the window trimmed to its length;
// the zoom and the loop histograms are kept until new ones come. Each axis
// of the run, one or several, keeps its series under "axes", one object each.
// Loaded by the shared worker (one stream for all tabs of a browser) and by
// the page itself where a browser has no shared workers.
const LIVE_SERIES = ["drive", "measured", "observer", "open_loop", "residual", "triggers"];

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
      e.axes.forEach((axis, i) => LiveWindow.merge(this.d.axes[i], axis, from));
      for (const key of ["t_end", "window_s", "column_s", "status", "pages"]) this.d[key] = e[key];
      if (e.histograms) this.d.histograms = e.histograms;
    }
    for (const axis of this.d.axes) {
      if (axis.zoom && !axis.zoom.t) axis.zoom = { t: LiveWindow.zoomTimes(axis.zoom), y: axis.zoom.y };
    }
    return this.d;
  }

  // One axis's new columns appended to what it holds, trimmed to the window.
  static merge(held, added, from) {
    for (const name of LIVE_SERIES) {
      let keep = 0;
      while (keep < held[name].t.length && held[name].t[keep] < from) keep += 1;
      held[name].t = held[name].t.slice(keep).concat(added[name].t);
      held[name].y = held[name].y.slice(keep).concat(added[name].y);
    }
    if (added.zoom) held.zoom = added.zoom;
  }
}
