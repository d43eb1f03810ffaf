/* linkdyn compare: every design's curves overlaid, with a hover readout. Inlined into
   compare.html; reads the JSON in #linkdyn-data; no network, no library. */
(function () {
  "use strict";
  var D = JSON.parse(document.getElementById("linkdyn-data").textContent);
  D.designs.forEach(function (d) { d.series = LD.unpack(d.series); });
  var el = LD.el, h = LD.h, fin = LD.fin, fmt = LD.fmt, nearest = LD.nearest, niceStep = LD.niceStep,
      range = LD.range;
  var PW = 360, PH = 220, ML = 52, MR = 14, MT = 22, MB = 32;
  var xmode = D.xaxes[0], box = document.getElementById("plots"), sel = document.getElementById("xaxis");
  function build() {
    box.innerHTML = "";
    D.panels.forEach(function (spec) {
      var panel = h("div", "panel", box), svg = el("svg", {viewBox: "0 0 " + PW + " " + PH}, panel);
      var xs = D.designs.map(function (d) { return d.series[xmode.key]; });
      var ys = D.designs.map(function (d) { return d.series[spec.key]; });
      var xr = range(xs), yr = range(ys), pad = 0.05 * (yr[1] - yr[0]);
      yr = [yr[0] - pad, yr[1] + pad];
      var x0 = ML, x1 = PW - MR, y0 = PH - MB, y1 = MT;
      var sx = function (v) { return x0 + (v - xr[0]) / (xr[1] - xr[0]) * (x1 - x0); };
      var sy = function (v) { return y0 - (v - yr[0]) / (yr[1] - yr[0]) * (y0 - y1); };
      var st = niceStep(yr[1] - yr[0], 5), v;
      for (v = Math.ceil(yr[0] / st) * st; v <= yr[1]; v += st) {
        el("line", {x1: x0, x2: x1, y1: sy(v), y2: sy(v), "class": "gridl"}, svg);
        el("text", {x: x0 - 4, y: sy(v) + 3.5, "text-anchor": "end", "class": "tick"}, svg).textContent = +v.toPrecision(6);
      }
      var xt = niceStep(xr[1] - xr[0], 6);
      for (v = Math.ceil(xr[0] / xt) * xt; v <= xr[1]; v += xt)
        el("text", {x: sx(v), y: y0 + 15, "text-anchor": "middle", "class": "tick"}, svg).textContent = +v.toPrecision(6);
      el("line", {x1: x0, x2: x0, y1: y0, y2: y1, "class": "axis"}, svg);
      el("line", {x1: x0, x2: x1, y1: y0, y2: y0, "class": "axis"}, svg);
      el("text", {x: x1, y: PH - 3, "text-anchor": "end", "class": "tick"}, svg).textContent = xmode.label;
      el("text", {x: 6, y: 14, "class": "ptitle"}, svg).textContent = spec.title + (spec.unit ? "  (" + spec.unit + ")" : "");
      D.designs.forEach(function (d, n) {
        var path = "", pen = false;
        for (var k = 0; k < ys[n].length; k++) {
          if (fin(xs[n][k]) && fin(ys[n][k])) { path += (pen ? "L" : "M") + sx(xs[n][k]).toFixed(1) + "," + sy(ys[n][k]).toFixed(1); pen = true; }
          else pen = false;
        }
        el("path", {d: path, "class": "series", stroke: d.color, "data-design": n}, svg);
      });
      var leg = h("div", "legend", panel);
      D.designs.forEach(function (d) { var it = h("span", "", leg), sw = h("i", "", it); sw.style.background = d.color; h("span", "", it, d.name); });
      var line = el("line", {"class": "hoverline", y1: y0, y2: y1}, svg), tip = h("div", "tooltip", panel);
      line.style.display = "none";
      var hit = el("rect", {x: x0, y: y1, width: x1 - x0, height: y0 - y1, fill: "transparent"}, svg);
      hit.addEventListener("pointermove", function (e) {
        var r = svg.getBoundingClientRect(), xv = xr[0] + ((e.clientX - r.left) / r.width * PW - x0) / (x1 - x0) * (xr[1] - xr[0]);
        tip.innerHTML = "";
        h("div", "tt", tip, xmode.label + " = " + fmt(xv));
        D.designs.forEach(function (d, n) {
          var k = nearest(xs[n], xv), row = h("div", "tr", tip), sw = h("i", "", row);
          sw.style.background = d.color;
          h("span", "", row, d.name + " ");
          var b = h("b", "", row, fmt(ys[n][k]) + (spec.unit ? " " + spec.unit : ""));
          b.setAttribute("data-design", n); b.setAttribute("data-frame", k);
        });
        line.setAttribute("x1", sx(xv)); line.setAttribute("x2", sx(xv)); line.style.display = "";
        LD.placeTip(tip, panel, e);
      });
      hit.addEventListener("pointerleave", function () { tip.style.display = "none"; line.style.display = "none"; });
    });
  }
  // every design's traced paths in one drawing, x and y to one scale (the file's length unit)
  function paths() {
    var pbox = document.getElementById("pathbox"), keys = Object.keys(D.paths || {});
    if (!keys.length) { pbox.textContent = "No traced point common to every design."; pbox.className = "note"; return; }
    var xs = [], ys = [];
    keys.forEach(function (p) { D.paths[p].forEach(function (xy) { xs.push(xy[0]); ys.push(xy[1]); }); });
    var xr = range(xs), yr = range(ys), W = 600, H = 380, M = 40;
    var s = Math.min((W - 2 * M) / (xr[1] - xr[0]), (H - 2 * M) / (yr[1] - yr[0]));
    var cx = (xr[0] + xr[1]) / 2, cy = (yr[0] + yr[1]) / 2;
    var fx = function (v) { return W / 2 + (v - cx) * s; }, fy = function (v) { return H / 2 - (v - cy) * s; };
    var svg = el("svg", {viewBox: "0 0 " + W + " " + H}, pbox);
    var st = niceStep((W - 2 * M) / s, 6), v;
    for (v = Math.ceil((cx - W / 2 / s) / st) * st; v <= cx + W / 2 / s; v += st) {
      el("line", {x1: fx(v), x2: fx(v), y1: 0, y2: H - 18, "class": "gridl"}, svg);
      el("text", {x: fx(v), y: H - 4, "text-anchor": "middle", "class": "tick"}, svg).textContent = LD.tickText(v, st);
    }
    for (v = Math.ceil((cy - H / 2 / s) / st) * st; v <= cy + H / 2 / s; v += st) {
      el("line", {x1: 30, x2: W, y1: fy(v), y2: fy(v), "class": "gridl"}, svg);
      el("text", {x: 28, y: fy(v) + 3.5, "text-anchor": "end", "class": "tick"}, svg).textContent = LD.tickText(v, st);
    }
    el("text", {x: W - 4, y: 12, "text-anchor": "end", "class": "tick"}, svg).textContent = "x, y (" + D.length_unit + "), one scale";
    keys.forEach(function (p) {
      D.paths[p].forEach(function (xy, n) {
        var d = "", pen = false;
        for (var k = 0; k < xy[0].length; k++) {
          if (fin(xy[0][k]) && fin(xy[1][k])) { d += (pen ? "L" : "M") + fx(xy[0][k]).toFixed(1) + "," + fy(xy[1][k]).toFixed(1); pen = true; }
          else pen = false;
        }
        el("path", {d: d, "class": "ppath", stroke: D.designs[n].color, "data-design": n, "data-point": p}, svg);
      });
    });
    var leg = h("div", "legend", pbox);
    D.designs.forEach(function (d) { var it = h("span", "", leg), sw = h("i", "", it); sw.style.background = d.color; h("span", "", it, d.name); });
    h("span", "note", leg, "points: " + keys.join(", "));
  }
  paths();
  D.xaxes.forEach(function (a, n) { var o = document.createElement("option"); o.value = n; o.textContent = a.label; sel.appendChild(o); });
  sel.addEventListener("change", function () { xmode = D.xaxes[+sel.value]; build(); });
  build();
  window.__linkdynCompare = true;
})();
