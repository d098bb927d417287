// The report's episode replay viewer (evaluation/replay_viewer.py embeds this file, inline; no network).
// Each <div class="rp"> holds the episodes of one scenario and seed, side by side, driven by one slider.
// Data: <script type="application/octet-stream" class="rp-data"> with a gzipped, base64 replay file
// (format: evaluation/replay.py). Keys: space = play/pause, arrows = one step (shift: ten), Home/End.
// For tests: window.petswarmReplays (one object per panel: frame, setFrame(k), play(), pause(),
// episodes[i].drawn = what was drawn last), window.petswarmReplaysReady once every panel is drawn.
(function () {
  "use strict";
  var ROLE_COLOR = {master: "#d62728", slave: "#1f77b4", waiting: "#8c8c8c", other: "#9467bd"};
  var SOURCE_COLOR = {policy: "#2ca02c", user: "#1f77b4", safety: "#d62728", "": "#e8e8e8"};
  var ACTIVITY_COLOR = {stop: "#bbbbbb", rest: "#c7b7e8", walk: "#f2a541", run: "#e0462b"};
  var PX_PER_M = 62;
  var panels = [];
  var active = null;
  window.petswarmReplays = panels;
  window.petswarmReplaysReady = false;

  function undelta(a) {
    var out = new Array(a.length), acc = 0;
    for (var i = 0; i < a.length; i++) {
      if (a[i] === null) { out[i] = null; } else { acc += a[i]; out[i] = acc; }
    }
    return out;
  }
  function expand(run, frames, empty) {  // a run [[frame, value], ...] -> one value per frame
    var out = new Array(frames), k = 0, cur = empty;
    for (var f = 0; f < frames; f++) {
      while (k < run.length && run[k][0] <= f) { cur = run[k][1]; k++; }
      out[f] = cur;
    }
    return out;
  }
  function decode(b64) {
    var bin = atob(b64.replace(/\s+/g, "")), bytes = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    var stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
    return new Response(stream).text().then(JSON.parse);
  }
  function prepare(d) {
    var F = d.frames;
    d.users.forEach(function (u) {
      ["x", "y", "th"].forEach(function (k) { u[k] = undelta(u[k]); });
      u.activityAt = expand(u.activity, F, "stop");
      u.stateAt = expand(u.state, F, "");
      u.masterAt = expand(u.master, F, -1);
    });
    d.robots.forEach(function (r) {
      ["x", "y", "th", "ref_x", "ref_y"].forEach(function (k) { r[k] = undelta(r[k]); });
      ["role", "state", "member", "arbiter"].forEach(function (k) { r[k + "At"] = expand(r[k], F, k === "member" ? -1 : ""); });
    });
    d.linksAt = expand(d.links, F, []);
    d.holderAt = expand(d.holder, F, []);
    d.errorAt = undelta(d.error);
    d.errMax = 0;
    d.errorAt.forEach(function (e) { if (e !== null && e > d.errMax) d.errMax = e; });
    return d;
  }

  function setupCanvas(c, w, h) {
    var r = window.devicePixelRatio || 1;
    c.width = Math.round(w * r); c.height = Math.round(h * r);
    c.style.width = w + "px"; c.style.height = h + "px";
    var g = c.getContext("2d");
    g.setTransform(r, 0, 0, r, 0, 0);
    return g;
  }
  function cursor(g, x, h) {
    g.strokeStyle = "#000"; g.lineWidth = 1;
    g.beginPath(); g.moveTo(x + 0.5, 0); g.lineTo(x + 0.5, h); g.stroke();
  }

  // -- the arena -----------------------------------------------------------------------------------
  function drawArena(ep, f) {
    var d = ep.data, g = ep.arena, W = ep.W, H = 330;
    var F = d.frames; if (f >= F) f = F - 1;
    var user = d.users[0], cx = user.x[f] / 1000, cy = user.y[f] / 1000;
    function X(x) { return W / 2 + (x / 1000 - cx) * PX_PER_M; }
    function Y(y) { return H / 2 - (y / 1000 - cy) * PX_PER_M; }
    g.clearRect(0, 0, W, H);
    g.fillStyle = "#fbfbf8"; g.fillRect(0, 0, W, H);
    g.strokeStyle = "#e6e6e6"; g.lineWidth = 1;  // 1 m grid
    for (var gx = Math.floor(cx - W / 2 / PX_PER_M); gx <= cx + W / 2 / PX_PER_M; gx++) {
      g.beginPath(); g.moveTo(X(gx * 1000), 0); g.lineTo(X(gx * 1000), H); g.stroke();
    }
    for (var gy = Math.floor(cy - H / 2 / PX_PER_M); gy <= cy + H / 2 / PX_PER_M; gy++) {
      g.beginPath(); g.moveTo(0, Y(gy * 1000)); g.lineTo(W, Y(gy * 1000)); g.stroke();
    }
    g.strokeStyle = "#444"; g.lineWidth = 3;
    d.arena.walls.forEach(function (w) { g.beginPath(); g.moveTo(X(w[0]), Y(w[1])); g.lineTo(X(w[2]), Y(w[3])); g.stroke(); });
    g.fillStyle = "#999";
    d.arena.boxes.forEach(function (b) {
      g.fillRect(X(b[0] - b[2] / 2), Y(b[1] + b[3] / 2), b[2] / 1000 * PX_PER_M, b[3] / 1000 * PX_PER_M);
    });
    d.users.forEach(function (u) {  // the user's path so far
      g.strokeStyle = "rgba(242,165,65,0.55)"; g.lineWidth = 2; g.setLineDash([5, 4]);
      g.beginPath();
      for (var k = 0; k <= f; k++) { if (k === 0) g.moveTo(X(u.x[k]), Y(u.y[k])); else g.lineTo(X(u.x[k]), Y(u.y[k])); }
      g.stroke(); g.setLineDash([]);
    });
    var drawn = {frame: f, t_s: f * d.dt_s, robots: [], users: [], holder: d.holderAt[f].slice(), links: d.linksAt[f].slice()};
    g.strokeStyle = "#9aa"; g.lineWidth = 1.5;  // formation links
    d.linksAt[f].forEach(function (p) {
      var a = d.robots[p[0]], b = d.robots[p[1]];
      g.beginPath(); g.moveTo(X(a.x[f]), Y(a.y[f])); g.lineTo(X(b.x[f]), Y(b.y[f])); g.stroke();
    });
    var R = d.robot_radius / 1000 * PX_PER_M;
    d.robots.forEach(function (r) {  // reference points and the error to them
      if (r.ref_x[f] === null) return;
      var rx = X(r.ref_x[f]), ry = Y(r.ref_y[f]), col = ROLE_COLOR[r.roleAt[f]] || "#555";
      g.strokeStyle = col; g.lineWidth = 1.5;
      g.beginPath(); g.moveTo(rx - 6, ry - 6); g.lineTo(rx + 6, ry + 6); g.moveTo(rx - 6, ry + 6); g.lineTo(rx + 6, ry - 6); g.stroke();
      g.setLineDash([2, 3]); g.beginPath(); g.moveTo(rx, ry); g.lineTo(X(r.x[f]), Y(r.y[f])); g.stroke(); g.setLineDash([]);
    });
    d.users.forEach(function (u, i) {
      var ux = X(u.x[f]), uy = Y(u.y[f]), ur = d.user_radius / 1000 * PX_PER_M, th = u.th[f] / 1000;
      g.fillStyle = "#f2a541"; g.beginPath(); g.arc(ux, uy, ur, 0, 2 * Math.PI); g.fill();
      g.strokeStyle = "#7a4b00"; g.lineWidth = 2;
      g.beginPath(); g.moveTo(ux, uy); g.lineTo(ux + Math.cos(th) * ur * 1.6, uy - Math.sin(th) * ur * 1.6); g.stroke();
      drawn.users.push({x: u.x[f] / 1000, y: u.y[f] / 1000, activity: u.activityAt[f], state: u.stateAt[f], master: u.masterAt[f]});
    });
    d.robots.forEach(function (r) {
      var x = X(r.x[f]), y = Y(r.y[f]), th = r.th[f] / 1000, role = r.roleAt[f], state = r.stateAt[f];
      var holds = d.holderAt[f].indexOf(r.id) >= 0;
      if (holds) { g.fillStyle = "rgba(255,215,0,0.55)"; g.beginPath(); g.arc(x, y, R + 6, 0, 2 * Math.PI); g.fill(); }
      g.fillStyle = ROLE_COLOR[role] || "#555"; g.beginPath(); g.arc(x, y, R, 0, 2 * Math.PI); g.fill();
      if (state === "emergency" || d.users.some(function (u) { return u.masterAt[f] === r.id && u.stateAt[f] === "emergency"; })) {
        g.strokeStyle = "#ff0000"; g.lineWidth = 3; g.beginPath(); g.arc(x, y, R + 3, 0, 2 * Math.PI); g.stroke();
      }
      g.strokeStyle = "#fff"; g.lineWidth = 2;
      g.beginPath(); g.moveTo(x, y); g.lineTo(x + Math.cos(th) * R, y - Math.sin(th) * R); g.stroke();
      g.fillStyle = "#111"; g.font = "11px sans-serif"; g.textAlign = "center";
      g.fillText("r" + r.id + (r.memberAt[f] >= 0 ? " m" + r.memberAt[f] : ""), x, y - R - 4);
      drawn.robots.push({id: r.id, type: r.type, x: r.x[f] / 1000, y: r.y[f] / 1000, th: th, role: role, state: state,
                         member: r.memberAt[f], arbiter: r.arbiterAt[f], holder: holds,
                         ref: r.ref_x[f] === null ? null : [r.ref_x[f] / 1000, r.ref_y[f] / 1000]});
    });
    g.fillStyle = "#333"; g.textAlign = "left"; g.font = "12px sans-serif";
    g.fillText("t = " + (f * d.dt_s).toFixed(1) + " s   1 m grid, view follows the user", 6, 14);
    ep.drawn = drawn;
  }

  // -- the time charts -------------------------------------------------------------------------------
  var LABEL_W = 92, RESET_W = 6;  // charts: labels, then the reset (bin 0) as a narrow column, then one column per step
  function colW(ep) { return (ep.W - LABEL_W - RESET_W) / Math.max(ep.panel.frames - 1, 1); }
  function colX(ep, k) { return k === 0 ? LABEL_W : LABEL_W + RESET_W + (k - 1) * colW(ep); }
  function colWidth(ep, k) { return k === 0 ? RESET_W - 1 : Math.max(colW(ep), 1); }
  function xOf(ep, f) { return colX(ep, f) + colWidth(ep, f) / 2; }
  function frameAt(ep, px) {
    if (px < LABEL_W + RESET_W) return 0;
    return 1 + Math.floor((px - LABEL_W - RESET_W) / colW(ep));
  }

  function drawError(ep, f) {
    var d = ep.data, g = ep.err, W = ep.W, H = 90, top = 8, bottom = 16;
    var max = Math.max(ep.panel.errMax, 1);
    g.clearRect(0, 0, W, H);
    g.fillStyle = "#333"; g.font = "11px sans-serif"; g.textAlign = "left";
    g.fillText("formation error", 2, 16); g.fillText("(mean, m)", 2, 29);
    g.fillStyle = "#777"; g.fillText((max / 1000).toFixed(2) + " m", LABEL_W + 3, top + 10);
    g.fillText("0", LABEL_W + 3, H - bottom - 2); g.fillStyle = "#333";
    g.strokeStyle = "#ccc"; g.strokeRect(LABEL_W, top, W - LABEL_W, H - top - bottom);
    g.strokeStyle = ROLE_COLOR.slave; g.lineWidth = 1.5; g.beginPath();
    var started = false;
    for (var k = 0; k < d.frames; k++) {
      var e = d.errorAt[k];
      if (e === null) continue;
      var px = xOf(ep, k), py = H - bottom - e / max * (H - top - bottom);
      if (!started) { g.moveTo(px, py); started = true; } else { g.lineTo(px, py); }
    }
    g.stroke();
    var e = d.errorAt[Math.min(f, d.frames - 1)];
    g.fillStyle = "#333"; g.fillText("time →", W - 40, H - 3);
    g.font = "bold 12px sans-serif";
    g.fillText(e === null ? "–" : (e / 1000).toFixed(3) + " m", 2, 50);
    cursor(g, xOf(ep, f), H - bottom);
  }

  function drawRadio(ep, f) {
    var d = ep.data, g = ep.radio, W = ep.W, kinds = ep.panel.kinds, row = 9, H = 14 + kinds.length * row;
    g.clearRect(0, 0, W, H);
    g.font = "9px sans-serif"; g.textAlign = "left"; g.fillStyle = "#333";
    g.fillText("radio: sent (blue) / lost (red) / collided (orange) per step; first column: reset", 2, 9);
    kinds.forEach(function (kind, j) {
      var y = 12 + j * row, idx = d.radio.kinds.indexOf(kind);
      g.fillStyle = "#333"; g.fillText(kind, 2, y + row - 2);
      g.fillStyle = "#f4f4f4"; g.fillRect(LABEL_W, y, W - LABEL_W, row - 1);
      if (idx < 0) return;
      var sent = d.radio.sent[idx], lost = d.radio.lost[idx], coll = d.radio.collided[idx];
      for (var k = 0; k < d.frames; k++) {
        var x = colX(ep, k), w = colWidth(ep, k);
        if (sent[k]) { g.fillStyle = "rgba(31,119,180," + Math.min(1, 0.35 + 0.2 * sent[k]) + ")"; g.fillRect(x, y, w, row - 1); }
        if (coll[k]) { g.fillStyle = "#ff7f0e"; g.fillRect(x, y + (row - 1) / 2, w, (row - 1) / 2); }
        if (lost[k]) { g.fillStyle = "#d62728"; g.fillRect(x, y, w, (row - 1) / 2); }
      }
    });
    cursor(g, xOf(ep, f), H);
  }

  function drawTracks(ep, f) {
    var d = ep.data, g = ep.tracks, W = ep.W, row = 10, user = d.users[0];
    var H = 16 + (3 + d.robots.length) * row;
    g.clearRect(0, 0, W, H);
    g.font = "9px sans-serif"; g.textAlign = "left";
    function band(y, label, colorAt) {
      g.fillStyle = "#333"; g.fillText(label, 2, y + row - 2);
      for (var k = 0; k < d.frames; k++) { g.fillStyle = colorAt(k); g.fillRect(colX(ep, k), y, colWidth(ep, k), row - 1); }
    }
    g.fillStyle = "#333";
    g.fillText("user activity (stop/rest/walk/run), user's robot state, commands; arbiter winner (policy/user/safety)", 2, 9);
    band(12, "user activity", function (k) { return ACTIVITY_COLOR[user.activityAt[k]] || "#ddd"; });
    band(12 + row, "user state", function (k) {
      var s = user.stateAt[k];
      return s === "emergency" ? "#d62728" : s === "exception" ? "#ff7f0e" : s === "leading" ? "#17becf" : s === "following" ? "#98df8a" : "#ddd";
    });
    var cy = 12 + 2 * row;
    g.fillStyle = "#333"; g.fillText("commands", 2, cy + row - 2);
    user.commands.forEach(function (c) {
      g.fillStyle = "#000"; g.fillRect(colX(ep, c[0]), cy, 2, row - 1);
    });
    d.robots.forEach(function (r, i) {
      band(12 + (3 + i) * row, "arbiter r" + r.id, function (k) { return SOURCE_COLOR[r.arbiterAt[k]] || "#e8e8e8"; });
    });
    cursor(g, xOf(ep, f), H);
  }

  function lastCommand(user, f) {
    var last = null;
    user.commands.forEach(function (c) { if (c[0] <= f) last = c; });
    return last;
  }

  function drawInfo(ep, f) {
    var d = ep.data; f = Math.min(f, d.frames - 1);
    var u = d.users[0], c = lastCommand(u, f);
    var rows = d.robots.map(function (r) {
      var e = r.ref_x[f] === null ? "–" : (Math.hypot(r.x[f] - r.ref_x[f], r.y[f] - r.ref_y[f]) / 1000).toFixed(2);
      return "<tr><td>r" + r.id + "</td><td>" + r.type + "</td><td style=\"color:" + (ROLE_COLOR[r.roleAt[f]] || "#555") + "\">" +
        r.roleAt[f] + "</td><td>" + r.stateAt[f] + "</td><td>" + (r.memberAt[f] >= 0 ? r.memberAt[f] : "–") + "</td><td>" +
        (r.arbiterAt[f] || "–") + "</td><td>" + e + "</td><td>" + (d.holderAt[f].indexOf(r.id) >= 0 ? "IR" : "") + "</td></tr>";
    }).join("");
    ep.info.innerHTML = "<div>user: <b>" + u.activityAt[f] + "</b>, robot state <b>" + u.stateAt[f] + "</b>, master r" +
      u.masterAt[f] + (c ? ", last command <b>" + c[1] + "</b> at " + (c[0] * d.dt_s).toFixed(1) + " s" : "") + "</div>" +
      "<table class=\"rp-table\"><tr><th>robot</th><th>type</th><th>role</th><th>state</th><th>member</th><th>arbiter</th>" +
      "<th>error (m)</th><th>token</th></tr>" + rows + "</table>";
  }

  // -- a panel: the episodes of one scenario and seed --------------------------------------------------
  function Panel(el, datas) {
    var self = this;
    this.el = el; this.frame = 0; this.playing = false; this.speed = 1;
    this.frames = Math.max.apply(null, datas.map(function (d) { return d.frames; }));
    this.errMax = Math.max.apply(null, datas.map(function (d) { return d.errMax; }));
    this.kinds = [];
    datas.forEach(function (d) { d.radio.kinds.forEach(function (k) { if (self.kinds.indexOf(k) < 0) self.kinds.push(k); }); });
    this.slider = el.querySelector(".rp-slider");
    this.slider.max = String(this.frames - 1);
    this.timeEl = el.querySelector(".rp-time");
    this.button = el.querySelector(".rp-play");
    var row = el.querySelector(".rp-row");
    var W = Math.max(360, Math.min(560, Math.floor((row.clientWidth || 1000) / datas.length) - 12));
    this.episodes = datas.map(function (d) {
      var box = document.createElement("div"); box.className = "rp-ep";
      box.innerHTML = "<div class=\"rp-title\">" + d.label.replace(/[<&>]/g, "") + " — " + d.scenario + ", seed " + d.seed + "</div>";
      var ep = {data: d, panel: self, W: W, drawn: null};
      ["arena", "err", "radio", "tracks"].forEach(function (name) {
        var c = document.createElement("canvas"); c.className = "rp-" + name; box.appendChild(c); ep[name + "El"] = c;
      });
      ep.info = document.createElement("div"); ep.info.className = "rp-info"; box.appendChild(ep.info);
      row.appendChild(box);
      ep.arena = setupCanvas(ep.arenaEl, W, 330);
      ep.err = setupCanvas(ep.errEl, W, 90);
      ep.radio = setupCanvas(ep.radioEl, W, 14 + self.kinds.length * 9);
      ep.tracks = setupCanvas(ep.tracksEl, W, 16 + (3 + d.robots.length) * 10);
      [ep.errEl, ep.radioEl, ep.tracksEl].forEach(function (c) {
        c.addEventListener("click", function (ev) {
          var rect = c.getBoundingClientRect();
          self.setFrame(frameAt(ep, ev.clientX - rect.left)); active = self;
        });
      });
      return ep;
    });
    this.slider.addEventListener("input", function () { active = self; self.setFrame(parseInt(self.slider.value, 10)); });
    this.button.addEventListener("click", function () { active = self; self.toggle(); });
    el.querySelector(".rp-speed").addEventListener("change", function (ev) { self.speed = parseFloat(ev.target.value); });
    el.addEventListener("mousedown", function () { active = self; });
    this.setFrame(0);
  }
  Panel.prototype.setFrame = function (k) {
    k = Math.max(0, Math.min(this.frames - 1, k | 0));
    this.frame = k;
    this.slider.value = String(k);
    var dt = this.episodes[0].data.dt_s;
    this.timeEl.textContent = "step " + k + " / " + (this.frames - 1) + "   t = " + (k * dt).toFixed(1) + " s";
    this.episodes.forEach(function (ep) {
      var f = Math.min(k, ep.data.frames - 1);
      drawArena(ep, f); drawError(ep, k); drawRadio(ep, k); drawTracks(ep, k); drawInfo(ep, f);
    });
  };
  Panel.prototype.play = function () {
    if (this.playing) return;
    var self = this, dt = this.episodes[0].data.dt_s * 1000, last = null, acc = 0;
    if (this.frame >= this.frames - 1) this.setFrame(0);
    this.playing = true; this.button.textContent = "❚❚ pause";
    function tick(ts) {
      if (!self.playing) return;
      if (last !== null) acc += (ts - last) * self.speed;
      last = ts;
      var n = Math.floor(acc / dt);
      if (n > 0) {
        acc -= n * dt;
        self.setFrame(self.frame + n);
        if (self.frame >= self.frames - 1) { self.pause(); return; }
      }
      window.requestAnimationFrame(tick);
    }
    window.requestAnimationFrame(tick);
  };
  Panel.prototype.pause = function () { this.playing = false; this.button.textContent = "▶ play"; };
  Panel.prototype.toggle = function () { if (this.playing) this.pause(); else this.play(); };

  document.addEventListener("keydown", function (ev) {
    var p = active || panels[0];
    if (!p) return;
    var t = ev.target, tag = t && t.tagName;
    if ((tag === "INPUT" && t.type !== "range") || tag === "SELECT" || tag === "TEXTAREA") return;
    var step = ev.shiftKey ? 10 : 1;
    if (ev.key === " " || ev.code === "Space") { p.toggle(); }
    else if (ev.key === "ArrowRight") { p.pause(); p.setFrame(p.frame + step); }
    else if (ev.key === "ArrowLeft") { p.pause(); p.setFrame(p.frame - step); }
    else if (ev.key === "Home") { p.pause(); p.setFrame(0); }
    else if (ev.key === "End") { p.pause(); p.setFrame(p.frames - 1); }
    else return;
    ev.preventDefault();
  });

  function start() {
    var els = Array.prototype.slice.call(document.querySelectorAll("div.rp"));
    if (typeof DecompressionStream === "undefined") {
      els.forEach(function (el) { el.querySelector(".rp-row").textContent = "This browser cannot unpack the replays (no DecompressionStream)."; });
      return;
    }
    Promise.all(els.map(function (el, i) {
      var blobs = Array.prototype.slice.call(el.querySelectorAll("script.rp-data"));
      return Promise.all(blobs.map(function (s) { return decode(s.textContent).then(prepare); })).then(function (datas) {
        panels[i] = new Panel(el, datas);
      });
    })).then(function () { window.petswarmReplaysReady = true; }, function (err) {
      console.error("replay viewer: " + err);
    });
  }
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start); else start();
})();
