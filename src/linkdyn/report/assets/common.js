/* linkdyn pages: helpers shared by report.js, compare.js and sweep.js, inlined before each
   page's own script as one global object, LD. No network, no library. */
var LD = (function () {
  "use strict";
  // the SVG namespace, as the HTML parser gives it (no URL written in the page)
  var NS = (function () { var d = document.createElement("div"); d.innerHTML = "<svg></svg>"; return d.firstChild.namespaceURI; })();
  // an SVG element with attributes, appended to parent
  function el(tag, attrs, parent) {
    var e = document.createElementNS(NS, tag);
    for (var k in attrs) e.setAttribute(k, attrs[k]);
    if (parent) parent.appendChild(e);
    return e;
  }
  // an HTML element with a class and text, appended to parent
  function h(tag, cls, parent, text) {
    var e = document.createElement(tag);
    if (cls) e.className = cls;
    if (text !== undefined) e.textContent = text;
    if (parent) parent.appendChild(e);
    return e;
  }
  // a page's series as its data carries them (report/data.py: packed): each the base64 text
  // of little-endian float64 values, NaN for a gap; unpacked to arrays of numbers, every digit
  // kept (a list of numbers passes through). What the page only draws comes as float32,
  // behind the prefix "f4:"
  function unpack(series) {
    var out = {};
    Object.keys(series).forEach(function (k) {
      var s = series[k];
      if (typeof s !== "string") { out[k] = s; return; }
      var f4 = s.slice(0, 3) === "f4:", b = atob(f4 ? s.slice(3) : s), u = new Uint8Array(b.length);
      for (var i = 0; i < b.length; i++) u[i] = b.charCodeAt(i);
      out[k] = Array.prototype.slice.call(f4 ? new Float32Array(u.buffer) : new Float64Array(u.buffer));
    });
    return out;
  }
  // the drawn geometry (report/data.py: drawn_geometry): each moving point's track and the
  // free-body view's mass-centre tracks unpacked in place
  function unpackGeom(G) {
    Object.keys(G.points).forEach(function (id) {
      var p = G.points[id];
      if (!p.static) G.points[id] = Object.assign({}, p, unpack(p));
    });
    (G.freebody || []).forEach(function (b) { if (b.com) b.com = unpack(b.com); });
    return G;
  }
  function fin(v) { return v !== null && v !== undefined && isFinite(v); }
  // sig significant digits (default 4), fixed between 1e-3 and 1e6, exponent outside
  function fmt(v, sig) {
    if (!fin(v)) return "–";
    sig = sig || 4;
    var a = Math.abs(v);
    if (a === 0) return "0";
    if (a >= 1e-3 && a < 1e6) return v.toFixed(Math.max(0, sig - 1 - Math.floor(Math.log10(a))));
    return v.toExponential(sig - 1);
  }
  // index of the finite value of arr nearest x
  function nearest(arr, x) {
    var best = 0, bd = Infinity;
    for (var i = 0; i < arr.length; i++) {
      if (!fin(arr[i])) continue;
      var d = Math.abs(arr[i] - x);
      if (d < bd) { bd = d; best = i; }
    }
    return best;
  }
  // a round tick step (1, 2 or 5 x 10^k) giving about n ticks over span
  function niceStep(span, n) {
    var s0 = span / n, mag = Math.pow(10, Math.floor(Math.log10(s0))), r = s0 / mag;
    return (r < 1.5 ? 1 : r < 3 ? 2 : r < 7 ? 5 : 10) * mag;
  }
  // a tick label with the decimals its step needs
  function tickText(v, step) {
    if (Math.abs(v) < step * 1e-6) v = 0;
    var a = Math.max(Math.abs(v), step);
    if (a >= 1e5 || step < 1e-4) return v.toExponential(Math.max(0, Math.round(Math.log10(a / step))));
    var dec = Math.max(0, -Math.floor(Math.log10(step) + 1e-9));
    return v.toFixed(dec);
  }
  // [lo, hi] of the finite values of some arrays, widened when (nearly) constant
  function range(arrs) {
    var lo = Infinity, hi = -Infinity;
    arrs.forEach(function (a) {
      for (var i = 0; i < a.length; i++) { var v = a[i]; if (fin(v)) { if (v < lo) lo = v; if (v > hi) hi = v; } }
    });
    if (!(hi >= lo)) { lo = -1; hi = 1; }
    var scale = Math.max(Math.abs(lo), Math.abs(hi));
    if (hi - lo <= 1e-9 * scale || hi === lo) {
      var pad = scale > 0 ? 0.1 * scale : 1;
      lo -= pad; hi += pad;
    }
    return [lo, hi];
  }
  // place a tooltip next to the pointer, inside its panel
  function placeTip(tip, panel, e) {
    var pr = panel.getBoundingClientRect();
    tip.style.display = "block";
    var left = e.clientX - pr.left + 14;
    if (left + tip.offsetWidth > pr.width) left = Math.max(0, e.clientX - pr.left - tip.offsetWidth - 14);
    tip.style.left = left + "px"; tip.style.top = Math.max(0, e.clientY - pr.top - tip.offsetHeight - 8) + "px";
  }
  // distance from the segment (ax, ay)-(bx, by) to the box b = [x0, y0, x1, y1] (0 where they
  // meet)
  function segBox(ax, ay, bx, by, b) {
    function inside(x, y) { return x >= b[0] && x <= b[2] && y >= b[1] && y <= b[3]; }
    function cross(px, py, qx, qy, rx, ry, sx, sy) {   // segments pq and rs intersect
      function o(x1, y1, x2, y2, x3, y3) { return (x2 - x1) * (y3 - y1) - (y2 - y1) * (x3 - x1); }
      var d1 = o(rx, ry, sx, sy, px, py), d2 = o(rx, ry, sx, sy, qx, qy),
          d3 = o(px, py, qx, qy, rx, ry), d4 = o(px, py, qx, qy, sx, sy);
      return d1 * d2 <= 0 && d3 * d4 <= 0;
    }
    function ptSeg(px, py) {
      var dx = bx - ax, dy = by - ay, L = dx * dx + dy * dy, u = L > 0 ? ((px - ax) * dx + (py - ay) * dy) / L : 0;
      u = Math.max(0, Math.min(1, u));
      return Math.hypot(px - ax - u * dx, py - ay - u * dy);
    }
    function ptBox(px, py) {
      return Math.hypot(Math.max(b[0] - px, 0, px - b[2]), Math.max(b[1] - py, 0, py - b[3]));
    }
    if (inside(ax, ay) || inside(bx, by)) return 0;
    var c = [[b[0], b[1]], [b[2], b[1]], [b[2], b[3]], [b[0], b[3]]];
    for (var i = 0; i < 4; i++) {
      var p = c[i], q = c[(i + 1) % 4];
      if (cross(ax, ay, bx, by, p[0], p[1], q[0], q[1])) return 0;
    }
    return Math.min(ptBox(ax, ay), ptBox(bx, by), ptSeg(c[0][0], c[0][1]), ptSeg(c[1][0], c[1][1]),
                    ptSeg(c[2][0], c[2][1]), ptSeg(c[3][0], c[3][1]));
  }
  // whether the box b touches a body's drawn shape: its outline's segments widened by r (half
  // its stroke), and for a closed outline (a plate) its inside too
  function hitsShape(b, sh) {
    var P = sh.pts, n = P.length;
    if (!n) return false;
    if (n === 1) return segBox(P[0][0], P[0][1], P[0][0], P[0][1], b) < sh.r;
    for (var i = 0; i + 1 < n + (sh.closed ? 1 : 0) && i < n; i++) {
      var p = P[i], q = P[(i + 1) % n];
      if (segBox(p[0], p[1], q[0], q[1], b) < sh.r) return true;
    }
    if (sh.closed) {   // the box's centre inside the polygon (even-odd)
      var cx = (b[0] + b[2]) / 2, cy = (b[1] + b[3]) / 2, inn = false;
      for (var k = 0, j = n - 1; k < n; j = k++)
        if ((P[k][1] > cy) !== (P[j][1] > cy) &&
            cx < (P[j][0] - P[k][0]) * (cy - P[k][1]) / (P[j][1] - P[k][1]) + P[k][0]) inn = !inn;
      return inn;
    }
    return false;
  }
  // labels placed clear of each other: each label goes to the first of a ring of positions
  // around its anchor whose box overlaps no label placed before it and no obstacle, inside
  // the W x H view, or is hidden this frame; sizes in screen pixels whatever the zoom
  // (textScale: view units per screen pixel). Items: {node, x, y, fs, r, prefer, must, edge,
  // leader}; a label that must show (must) takes its first position inside the view when none
  // is clear; a label with a place at the edge (edge: a force's value) that finds no room near
  // its anchor goes to the first clear slot down the view's right edge, then its left, joined
  // to its anchor by its leader line, and never leaves the view. A label with a place at the
  // edge also keeps clear of the bodies' drawn outlines (shapes: {pts: [[x, y], ...], r,
  // closed}: a bar as a thick line, a plate as a filled polygon with its thick border; see
  // hitsShape), near its anchor and at the edge.
  function placer(VW, VH) {
    var widthCache = {};
    function textBox(node, fs) {
      // digits share one width: "J3 135.8 N" and "J3 121.4 N" are measured once
      var key = node.textContent.replace(/[0-9]/g, "0") + "|" + fs + "|" + (node.getAttribute("font-weight") || "") + (node.getAttribute("font-style") || "");
      if (!(key in widthCache)) {
        node.setAttribute("font-size", fs);
        var w = 0;
        try { w = node.getComputedTextLength(); } catch (err) { w = 0; }
        widthCache[key] = w > 0 ? w : 0.62 * fs * node.textContent.length;
      }
      return [widthCache[key], fs];
    }
    var DIRS = [[1, -1], [1, 1], [-1, -1], [-1, 1], [0, -1], [0, 1], [1, 0], [-1, 0]];
    function overlaps(b, boxes) {
      for (var i = 0; i < boxes.length; i++) {
        var o = boxes[i];
        if (b[0] < o[2] && o[0] < b[2] && b[1] < o[3] && o[1] < b[3]) return true;
      }
      return false;
    }
    return function place(items, obstacles, textScale, shapes) {
      var placed = obstacles.slice();
      shapes = shapes || [];
      function free(b, it) {
        if (overlaps(b, placed)) return false;
        if (!it.edge) return true;
        for (var i = 0; i < shapes.length; i++) if (hitsShape(b, shapes[i])) return false;
        return true;
      }
      items.forEach(function (it) {
        if (it.leader) it.leader.style.display = "none";
        if (it.node.style.display === "none" || !fin(it.x) || !fin(it.y)) return;
        var fs = it.fs * textScale, wh = textBox(it.node, fs), w = wh[0] + 2, hgt = fs * 1.05;
        var pad = 2 * textScale, best = null, first = null;
        var dirs = it.prefer ? [it.prefer].concat(DIRS) : DIRS;
        for (var ring = 0; ring < 4 && !best; ring++) {
          var r = (it.r || 6) * textScale + ring * 10 * textScale;
          for (var n = 0; n < dirs.length; n++) {
            var dx = dirs[n][0], dy = dirs[n][1];
            var x0 = it.x + dx * r - (dx < 0 ? w : dx === 0 ? w / 2 : 0);
            var y0 = it.y + dy * r - (dy < 0 ? hgt : dy === 0 ? hgt / 2 : 0);
            var b = [x0 - pad, y0 - pad, x0 + w + pad, y0 + hgt + pad];
            if (b[0] < 0 || b[2] > VW || b[1] < 0 || b[3] > VH) continue;
            first = first || b;
            if (free(b, it)) { best = b; break; }
          }
        }
        if (!best && it.must) best = first;
        var led = false;
        if (!best && it.edge) {
          // a column of slots down the right edge, then the left: the first clear one (in a
          // view too crowded for any, the first, on top of another label rather than none)
          var step = hgt + 2 * pad + textScale, slots = [];
          for (var side = 0; side < 2; side++)
            for (var sy = 0; sy + hgt + 2 * pad <= VH; sy += step) {
              var sx = side === 0 ? VW - w - 2 * pad : 0;
              slots.push([sx, sy, sx + w + 2 * pad, sy + hgt + 2 * pad]);
            }
          for (var n2 = 0; n2 < slots.length && !best; n2++) if (free(slots[n2], it)) best = slots[n2];
          for (var n3 = 0; n3 < slots.length && !best; n3++) if (!overlaps(slots[n3], placed)) best = slots[n3];
          best = best || slots[0] || [0, 0, w + 2 * pad, hgt + 2 * pad];
          led = true;
        }
        if (it.leader) {
          it.leader.style.display = led ? "" : "none";
          if (led) {  // from the label's nearest point to its anchor
            var lx = Math.min(Math.max(it.x, best[0]), best[2]), ly = Math.min(Math.max(it.y, best[1]), best[3]);
            it.leader.setAttribute("x1", lx.toFixed(1)); it.leader.setAttribute("y1", ly.toFixed(1));
            it.leader.setAttribute("x2", it.x.toFixed(1)); it.leader.setAttribute("y2", it.y.toFixed(1));
            it.leader.setAttribute("stroke-width", (0.8 * textScale).toFixed(2));
          }
        }
        if (!best) { it.node.style.display = "none"; return; }  // no room: left out this frame
        placed.push(best);
        it.node.setAttribute("font-size", fs.toFixed(2));
        it.node.setAttribute("text-anchor", "start");
        it.node.setAttribute("x", (best[0] + pad).toFixed(1));
        it.node.setAttribute("y", (best[1] + pad + 0.8 * hgt).toFixed(1));
      });
    };
  }
  // the colours of the forces drawn on a view, each kind its own, named by the page's force key
  var FORCE = {joint: "#c62828", load: "#1565c0", driver: "#2e7d32", shaking: "#6a1b9a",
               friction: "#ef6c00", weight: "#6d4c41"};
  return {NS: NS, FORCE: FORCE, unpack: unpack, unpackGeom: unpackGeom, placer: placer, hitsShape: hitsShape, el: el, h: h, fin: fin, fmt: fmt, nearest: nearest, niceStep: niceStep,
          tickText: tickText, range: range, placeTip: placeTip};
})();
