// psmat lab page: plain JavaScript, no dependencies. Draws the display messages the server
// pushes over /ws (raw counts, pressure, CoP trace) and drives the JSON API (record, markers,
// sessions, replay, the box's calibration walk-through). Every request carries the page's token.
"use strict";

(function () {
  const token = new URLSearchParams(window.location.search).get("token") || "";
  const state = { latest: null, dirty: false, trace: [], recording: false, replay: null, extent: null,
    cal: null, calPending: false };
  const lab = window.psmatLab = {
    framesDrawn: 0, messages: 0, lastFrameDeviceTimeUs: null, lastLatencyMs: null, connected: false,
    // arrival of each frame message (for python -m psmat.bench lab): the device clock mapped onto the
    // host's wall clock by the least-delayed frame so far (min of host_time_s - device time, ms), and
    // the latency from each frame's device time to its arrival here, the last 2000 kept
    deviceClockOffsetMs: null, arrivalLatenciesMs: [],
  };
  const $ = (id) => document.getElementById(id);

  function showError(text) {
    $("error").textContent = text || "";
  }

  async function api(method, path, body) {
    const opts = { method, headers: { "Authorization": "Bearer " + token } };
    if (body !== undefined) {
      opts.headers["Content-Type"] = "application/json";
      opts.body = JSON.stringify(body);
    }
    const resp = await fetch(path, opts);
    let data = null;
    try { data = await resp.json(); } catch (e) { data = null; }
    if (!resp.ok) {
      const msg = (data && data.error) || (resp.status + " " + resp.statusText);
      showError(msg);
      throw new Error(msg);
    }
    showError("");
    return data;
  }

  // ---------------------------------------------------------------- colours
  const STOPS = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];  // viridis-like
  function colour(v) {  // v in 0..1
    if (!(v > 0)) return STOPS[0];
    if (v >= 1) return STOPS[STOPS.length - 1];
    const x = v * (STOPS.length - 1), i = Math.floor(x), f = x - i;
    const a = STOPS[i], b = STOPS[i + 1];
    return [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2])];
  }

  function decode(b64, Type) {
    const bin = atob(b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    return new Type(bytes.buffer);
  }

  // image (rows x cols, row 0 at the bottom) scaled lo..hi onto the canvas
  function drawImage(canvas, data, rows, cols, lo, hi) {
    const ctx = canvas.getContext("2d");
    const w = canvas.width, h = canvas.height, cw = w / cols, ch = h / rows;
    const span = hi > lo ? hi - lo : 1;
    for (let r = 0; r < rows; r++) {
      for (let c = 0; c < cols; c++) {
        const [R, G, B] = colour((data[r * cols + c] - lo) / span);
        ctx.fillStyle = "rgb(" + (R | 0) + "," + (G | 0) + "," + (B | 0) + ")";
        ctx.fillRect(c * cw, h - (r + 1) * ch, Math.ceil(cw), Math.ceil(ch));
      }
    }
  }

  function drawCopMarker(canvas, cop, extent) {
    if (!cop || !extent) return;
    const [x0, x1, y0, y1] = extent;
    const px = (cop[0] - x0) / (x1 - x0) * canvas.width;
    const py = canvas.height - (cop[1] - y0) / (y1 - y0) * canvas.height;
    const ctx = canvas.getContext("2d");
    ctx.strokeStyle = "cyan";
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.moveTo(px - 8, py); ctx.lineTo(px + 8, py);
    ctx.moveTo(px, py - 8); ctx.lineTo(px, py + 8);
    ctx.stroke();
  }

  function drawTrace(canvas, trace) {
    const ctx = canvas.getContext("2d");
    const w = canvas.width, h = canvas.height, pad = 34;
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, w, h);
    ctx.strokeStyle = "#ccc";
    ctx.strokeRect(pad, 6, w - pad - 6, h - pad - 6);
    if (trace.length < 2) return;
    const tEnd = trace[trace.length - 1][0];
    let lo = Infinity, hi = -Infinity;
    for (const p of trace) { lo = Math.min(lo, p[1], p[2]); hi = Math.max(hi, p[1], p[2]); }
    const span = Math.max(hi - lo, 1);
    lo -= 0.1 * span; hi += 0.1 * span;
    const X = (t) => pad + (1 + (t - tEnd) / 10) * (w - pad - 6);
    const Y = (v) => 6 + (1 - (v - lo) / (hi - lo)) * (h - pad - 6);
    ctx.fillStyle = "#333";
    ctx.font = "11px sans-serif";
    ctx.fillText(hi.toFixed(1), 2, 14);
    ctx.fillText(lo.toFixed(1), 2, h - pad);
    ctx.fillText("-10 s", pad, h - 12);
    ctx.fillText("now", w - 30, h - 12);
    for (const [k, col] of [[1, "#1f77b4"], [2, "#d62728"]]) {
      ctx.strokeStyle = col;
      ctx.lineWidth = 1.3;
      ctx.beginPath();
      trace.forEach((p, i) => { if (i === 0) ctx.moveTo(X(p[0]), Y(p[k])); else ctx.lineTo(X(p[0]), Y(p[k])); });
      ctx.stroke();
    }
  }

  function draw() {
    window.requestAnimationFrame(draw);
    if (!state.dirty || !state.latest) return;
    state.dirty = false;
    const m = state.latest;
    const rows = m.shape[0], cols = m.shape[1];
    const counts = decode(m.counts, Uint16Array), pressure = decode(m.pressure, Float32Array);
    drawImage($("raw"), counts, rows, cols, m.counts_range[0], m.counts_range[1]);
    drawImage($("pressure"), pressure, rows, cols, 0, Math.max(m.pressure_max, 1e-6));
    drawCopMarker($("pressure"), m.cop_cm, m.extent_cm);
    $("raw-scale").textContent = m.counts_range[0] + " ... " + m.counts_range[1] + " counts";
    $("pressure-scale").textContent = "0 ... " + m.pressure_max.toFixed(1) + " kPa";
    drawTrace($("cop"), state.trace);
    lab.framesDrawn += 1;
    lab.lastFrameDeviceTimeUs = m.device_time_us;
    lab.lastLatencyMs = Date.now() - m.host_time_s * 1000;  // server and page on one machine, one clock
  }

  function onFrame(m) {
    lab.messages += 1;
    if (m.device_time_us >= 0) {
      const arrived = Date.now(), off = m.host_time_s * 1000 - m.device_time_us / 1000;
      if (lab.deviceClockOffsetMs === null || off < lab.deviceClockOffsetMs ||
          m.device_time_us < (lab.lastArrivalDeviceTimeUs ?? -1)) lab.deviceClockOffsetMs = off;  // new source
      lab.lastArrivalDeviceTimeUs = m.device_time_us;
      lab.arrivalLatenciesMs.push(arrived - (m.device_time_us / 1000 + lab.deviceClockOffsetMs));
      if (lab.arrivalLatenciesMs.length > 2000) lab.arrivalLatenciesMs.splice(0, 1000);
    }
    state.latest = m;
    state.dirty = true;
    if (m.trace.length) {
      const last = state.trace.length ? state.trace[state.trace.length - 1][0] : -Infinity;
      if (m.trace[0][0] < last) state.trace = [];  // a replay seeked back, or a new source
      state.trace.push(...m.trace);
      const tEnd = state.trace[state.trace.length - 1][0];
      while (state.trace.length && state.trace[0][0] < tEnd - 10) state.trace.shift();
    }
    showRates(m.rates);
  }

  function fmt(v) { return v === null || v === undefined ? "-" : Number(v).toFixed(1); }

  function showRates(r) {
    if (!r) return;
    $("rates").textContent = "received " + fmt(r.received_hz) + " frames/s, processed " + fmt(r.processed_hz) +
      " frames/s, display " + fmt(r.displayed_hz) + " updates/s";
  }

  // ---------------------------------------------------------------- WebSocket (reconnects)
  let delay = 250;
  function connect() {
    const proto = window.location.protocol === "https:" ? "wss://" : "ws://";
    const ws = new WebSocket(proto + window.location.host + "/ws?token=" + encodeURIComponent(token));
    ws.onopen = () => { lab.connected = true; delay = 250; $("connection").textContent = "connected";
      $("connection").className = "on"; };
    ws.onmessage = (ev) => {
      const m = JSON.parse(ev.data);
      if (m.type === "frame") onFrame(m);
      else if (m.type === "hello") applyStatus(m.status);
    };
    ws.onclose = () => {
      lab.connected = false;
      $("connection").textContent = "disconnected, retrying";
      $("connection").className = "off";
      setTimeout(connect, delay);
      delay = Math.min(delay * 2, 4000);
    };
  }

  // ---------------------------------------------------------------- status, recording, markers
  function applyStatus(s) {
    if (!s) return;
    state.recording = !!s.recording;
    $("record").textContent = state.recording ? "Stop recording" : "Start recording";
    $("record").className = state.recording ? "recording" : "";
    if (s.device) {
      $("device").textContent = s.device.kind + " " + s.device.shape.join("x") + " on " + s.device.port +
        (s.device.profile ? " (" + s.device.profile + ")" : "");
    }
    // what the device's counters say went wrong, with what to check (as psmat record says it)
    const warnings = (s.device && s.device.warnings) || [];
    $("warnings").replaceChildren(...warnings.map((w) => Object.assign(document.createElement("li"), {textContent: w})));
    $("warnings").hidden = warnings.length === 0;
    if (s.record) {
      const md = s.record.metadata || {};
      $("record-state").textContent = s.record.stopped
        ? "recording STOPPED (" + s.record.stopped + "): " + s.session + " keeps its first " + s.record.frames +
          " frames; press Stop recording"
        : "recording " + s.session + ": " + s.record.frames + " frames, " +
          s.record.events + " markers, " + s.record.elapsed_s.toFixed(1) + " s";
      for (const k of ["subject", "trial", "note"]) {  // a reloaded page shows the running trial
        if (document.activeElement !== $(k) && !$(k).value && md[k]) $(k).value = md[k];
      }
    } else {
      $("record-state").textContent = s.last_stop ? "last: " + s.last_stop.session : "";
    }
    showRates(s.rates);
    state.replay = s.replay;
    if (s.replay) {
      $("seek").max = s.replay.duration_s;
      if (document.activeElement !== $("seek")) $("seek").value = s.replay.position_s;
      $("replay-state").textContent = s.replay.name + " " + s.replay.position_s.toFixed(1) + " / " +
        s.replay.duration_s.toFixed(1) + " s" + (s.replay.paused ? " (paused)" : "") +
        (s.replay.finished ? " (end)" : "");
    } else {
      $("replay-state").textContent = "live";
    }
    if (!state.calPending) {  // a reloaded page finds the walk-through where it was
      state.cal = s.calibration || null;
      renderCal();
      if (s.calibrated && !$("cal-result").textContent) showCalResult(s.calibrated, "last calibration");
    }
  }

  async function poll() {
    try { applyStatus(await api("GET", "/api/status")); } catch (e) { /* shown */ }
    setTimeout(poll, 1000);
  }

  function showSway(sw) {
    if (!sw || !sw.metrics) { $("sway").textContent = sw && sw.error ? "no metrics: " + sw.error : "-"; return; }
    const m = sw.metrics;
    const rows = [["SD M-L", m.sd_ml_cm, "cm"], ["SD A-P", m.sd_ap_cm, "cm"], ["range M-L", m.range_ml_cm, "cm"],
      ["range A-P", m.range_ap_cm, "cm"], ["path", m.path_cm, "cm"], ["mean velocity", m.velocity_cm_s, "cm/s"],
      ["95 % ellipse area", m.area95_cm2, "cm²"], ["mean frequency", m.mean_freq_hz, "Hz"]];
    const table = document.createElement("table");
    for (const [name, v, unit] of rows) {
      const tr = table.insertRow();
      tr.insertCell().textContent = name;
      tr.insertCell().textContent = Number(v).toFixed(3) + " " + unit;
    }
    $("sway").replaceChildren(table);
  }

  async function toggleRecord() {
    $("record").disabled = true;
    try {
      if (state.recording) {
        const out = await api("POST", "/api/record/stop");
        showSway(out.sway);
        refreshSessions();
      } else {
        await api("POST", "/api/record/start", { subject: $("subject").value, trial: $("trial").value,
          note: $("note").value });
      }
      applyStatus(await api("GET", "/api/status"));
    } catch (e) { /* shown */ } finally { $("record").disabled = false; }
  }

  async function mark(label) {
    try {
      const out = await api("POST", "/api/marker", { label });
      const li = document.createElement("div");
      li.textContent = label + " at " + new Date(out.host_time_s * 1000).toLocaleTimeString();
      $("marker-log").prepend(li);
    } catch (e) { /* shown */ }
  }

  // ---------------------------------------------------------------- sessions and replay
  async function refreshSessions() {
    try {
      const out = await api("GET", "/api/sessions");
      const ul = $("sessions");
      ul.replaceChildren();
      for (const s of out.sessions) {
        const li = document.createElement("li");
        const b = document.createElement("button");
        b.type = "button";
        b.textContent = "Replay";
        b.addEventListener("click", () => replay("open", { session: s.name, speed: Number($("speed").value) }));
        li.append(b, " " + s.name + " (" + (s.bytes / 1024).toFixed(0) + " KiB)");
        ul.append(li);
      }
    } catch (e) { /* shown */ }
  }

  async function replay(action, body) {
    try {
      await api("POST", "/api/replay/" + action, body || {});
      if (action === "open" || action === "close") state.trace = [];
      applyStatus(await api("GET", "/api/status"));
    } catch (e) { /* shown */ }
  }

  // ---------------------------------------------------------------- calibration of the box
  function calCurrent() {
    return state.cal ? state.cal.steps.find((st) => !st.done) || null : null;
  }

  function pct(v) { return (100 * v).toFixed(1) + " %"; }

  function renderCal() {
    const c = state.cal, cur = calCurrent(), busy = state.calPending || (c && c.busy);
    $("calibrate").disabled = !!busy;
    $("calibrate").textContent = c ? "Start again" : "Start";
    $("cal-record").disabled = !c || !cur || !!busy;
    $("cal-finish").disabled = !c || !c.ready || !!busy;
    $("cal-cancel").disabled = !c;
    if (!c) { $("cal-diag").replaceChildren(); return; }
    const n = c.steps.length, k = cur ? c.steps.indexOf(cur) + 1 : n;
    $("cal-step").textContent = busy ? "Recording the step (" + c.seconds + " s): leave the set-up as it is..." :
      cur ? "Step " + k + " of " + n + ": " + cur.instruction : "All steps recorded: press Finish.";
    const items = [];
    for (const st of c.steps) {
      if (!st.diagnostics) continue;
      const d = st.diagnostics, li = document.createElement("li");
      li.textContent = st.key + ": " + d.frames + " frames, mean " + d.mean_count.toFixed(1) + " counts, spread " +
        d.spread_count.toFixed(2) + ", clipped " + pct(d.clipped_fraction);
      items.push(li);
    }
    $("cal-diag").replaceChildren(...items);
  }

  function showCalResult(r, what) {
    const radc = r.r_adc_ohm === null ? "beyond the ADC's resolution" : (r.r_adc_ohm / 1e6).toFixed(3) + " MΩ";
    $("cal-result").textContent = (what ? what + ": " : "") + "R_adc = " + radc + ", R_mux = " +
      r.r_mux_ohm.toFixed(1) + " Ω (box " + (r.serial || "without serial") + "), written to " + r.path +
      "; the trials recorded from now on store it.";
  }

  async function calDo(action, body) {
    state.calPending = true;
    renderCal();
    try {
      const out = await api("POST", "/api/calibrate/" + action, body || {});
      if (action === "start") { state.cal = out; $("cal-result").textContent = ""; }
      else if (action === "step") state.cal = out.calibration;
      else if (action === "finish") {
        state.cal = null;
        $("cal-step").textContent = "Done: plug the mat back in.";
        showCalResult(out, "");
      } else { state.cal = null; $("cal-step").textContent = "Calibration cancelled."; }
    } catch (e) { /* shown */ } finally {
      state.calPending = false;
      renderCal();
    }
  }

  $("calibrate").addEventListener("click", () => calDo("start"));
  $("cal-record").addEventListener("click", () => {
    const cur = calCurrent();
    if (!cur) return;
    calDo("step", cur.step === "open" ? { step: "open" } : { step: "short", row: cur.row, col: cur.col });
  });
  $("cal-finish").addEventListener("click", () => calDo("finish"));
  $("cal-cancel").addEventListener("click", () => calDo("cancel"));

  $("record").addEventListener("click", toggleRecord);
  for (const b of document.querySelectorAll("button.marker[data-label]")) {
    b.addEventListener("click", () => mark(b.dataset.label));
  }
  document.addEventListener("keydown", (ev) => {
    if (ev.target instanceof HTMLInputElement || ev.target instanceof HTMLSelectElement) return;
    if (ev.key >= "1" && ev.key <= "9") {
      const b = document.querySelectorAll("button.marker[data-label]")[Number(ev.key) - 1];
      if (b) { ev.preventDefault(); mark(b.dataset.label); }
    }
  });
  $("refresh").addEventListener("click", refreshSessions);
  $("play").addEventListener("click", () => replay("play"));
  $("pause").addEventListener("click", () => replay("pause"));
  $("seek").addEventListener("change", () => replay("seek", { t_s: Number($("seek").value) }));
  $("speed").addEventListener("change", () => { if (state.replay) replay("speed", { speed: Number($("speed").value) }); });
  $("live").addEventListener("click", () => replay("close"));

  connect();
  poll();
  refreshSessions();
  window.requestAnimationFrame(draw);
})();
