// thermocue monitor: the page. Charts are uPlot's; the data come from the server-sent event
// stream ("events", see experiments/monitor/stream.py) and "trace?file=" for a finished attempt.
"use strict";
(function () {
  const $ = (id) => document.getElementById(id);
  // read by the browser tests and benchmarks/bench_monitor.py: history holds [Date.now() ms,
  // the last frame's device time] per redraw of the running trial (the last 20,000)
  const stats = { updates: 0, frames: 0, lastT: null, lastUpdateMs: null, renders: 0, history: [] };
  window.monitorStats = stats;
  let meta = null;
  let rows = [];
  let live = null;                             // {key, cols, fault}
  let dirty = false;

  const fmt = (v, d) => (v === null || v === undefined || v === "") ? "" : Number(v).toFixed(d);
  const clock = (s) => {
    if (s === null || s === undefined) return "–";
    s = Math.max(0, Math.floor(s));
    const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), r = s % 60;
    const mm = h ? String(m).padStart(2, "0") : String(m);
    return (h ? h + ":" : "") + mm + ":" + String(r).padStart(2, "0");
  };

  function width() { return Math.max(480, Math.min(1100, document.body.clientWidth - 40)); }

  function makeCharts(tempEl, forceEl) {
    const x = { label: "device time (s)" };
    const temp = new uPlot({
      title: "Pad temperature and its target", width: width(), height: 280,
      scales: { x: { time: false } },
      series: [x,
        { label: "pad (contact) °C", stroke: "#d62728", width: 3, points: { show: false } },
        { label: "target °C", stroke: "#111", dash: [5, 4], width: 1.5, points: { show: false } },
        { label: "finger (IR) °C", stroke: "#1f77b4", width: 1, points: { show: false } },
        { label: "fault", stroke: "#000", fill: "#f00", width: 0, paths: () => null,
          points: { show: true, size: 14, width: 2, stroke: "#000", fill: "#f00" } }],
      axes: [{ label: "device time (s)" }, { label: "°C" }],
    }, [[], [], [], [], []], tempEl);
    const force = new uPlot({
      title: "Contact force (four sensors summed) and the threshold", width: width(), height: 180,
      scales: { x: { time: false } },
      series: [x,
        { label: "force N", stroke: "#2ca02c", width: 2, points: { show: false } },
        { label: "threshold N", stroke: "#999", dash: [4, 4], width: 1, points: { show: false } }],
      axes: [{ label: "device time (s)" }, { label: "N" }],
    }, [[], [], []], forceEl);
    return { temp, force };
  }

  const liveCharts = makeCharts($("live-temp"), $("live-force"));
  let picked = null;
  window.monitorCharts = { live: liveCharts, picked: null };   // read by the browser tests

  function seriesOf(cols, fault) {
    const n = cols.t.length;
    const mark = new Array(n).fill(null);
    if (fault && fault.time_s !== null) {
      const i = cols.t.lastIndexOf(fault.time_s);
      if (i >= 0) mark[i] = cols.contact[i] !== null ? cols.contact[i] : fault.value_C;
    }
    const thr = meta && meta.force_threshold_N !== null ? meta.force_threshold_N : null;
    return {
      temp: [cols.t, cols.contact, cols.target, cols.finger, mark],
      force: [cols.t, cols.force, new Array(n).fill(thr)],
    };
  }

  function draw(charts, cols, fault) {
    const s = seriesOf(cols, fault);
    charts.temp.setData(s.temp);
    charts.force.setData(s.force);
  }

  function render() {
    dirty = false;
    if (live) {
      draw(liveCharts, live.cols, live.fault);
      stats.renders += 1;
      if (stats.history.length >= 20000) stats.history.splice(0, 10000);
      stats.history.push([Date.now(), stats.lastT]);
    }
  }

  function faultText(f, prefix) {
    return prefix + "fault " + f.code + ": " + f.words + (f.message ? " (" + f.message + ")" : "");
  }

  function onTrace(tr) {
    if (tr.reset || !live || String(live.key) !== String(tr.key)) {
      live = { key: tr.key, cols: { t: [], target: [], contact: [], finger: [], force: [], state: [] }, fault: null };
    }
    for (const k of Object.keys(live.cols)) {
      if (tr[k]) Array.prototype.push.apply(live.cols[k], tr[k]);
    }
    if (tr.fault) live.fault = tr.fault;
    stats.frames = live.cols.t.length;
    stats.lastT = live.cols.t.length ? live.cols.t[live.cols.t.length - 1] : null;
    $("live-title").textContent = "Trial " + tr.key[0] + ", attempt " + tr.key[1] +
      (tr.done ? " (ended)" : " (running)");
    $("live-note").textContent = live.fault ? faultText(live.fault, "") + " (marked ● on the trace)"
      : (tr.done && !live.cols.t.length ? "no trace: the display did not run this attempt" : "");
    $("live-note").className = live.fault ? "faultnote" : "note";
    if (!dirty) { dirty = true; requestAnimationFrame(render); }
  }

  function onStatus(s) {
    const st = $("state");
    st.textContent = s.state; st.className = "state " + s.state;
    let t = "trial –";
    if (s.trial !== null && s.trial !== undefined) {
      t = "trial " + s.trial + " of " + (meta ? meta.n_trials : "?");
      if (s.block) {
        const size = meta && meta.block_sizes ? meta.block_sizes[s.block] : null;
        t += " · block " + s.block + (s.block_position && size ? " (" + s.block_position + " of " + size + ")" : "");
      }
      if (s.attempt > 1) t += " · attempt " + s.attempt;
    }
    $("trial").textContent = t;
    $("machine").textContent = s.end ? "session " + s.end + (s.end_reason ? " (" + s.end_reason + ")" : "")
      : (s.machine_words || "");
    let c = "elapsed " + clock(s.elapsed_s);
    if (s.end === "finished") c += " · finished";
    else if (s.time_left_s !== null && s.time_left_s !== undefined)
      c += " · about " + clock(s.time_left_s) + " left (measured trial durations, rewarm included)";
    else if (!s.end) c += " · time left: after the first trial";
    $("clock").textContent = c;
    const f = $("fault");
    if (s.last_fault) {
      f.hidden = false;
      f.textContent = faultText(s.last_fault, "last fault (trial " + s.last_fault.trial + ", attempt " + s.last_fault.attempt + "): ");
    }
  }

  function onRows(from, list) {
    if (from === 0) { rows = []; $("trials").tBodies[0].textContent = ""; }
    const body = $("trials").tBodies[0];
    for (const r of list) {
      rows.push(r);
      const tr = document.createElement("tr");
      tr.className = r.status;
      tr.dataset.trace = r.trace_file || "";
      const answer = r.answer === null || r.answer === undefined ? "" :
        r.answer + (r.correct === 1 || r.correct === "1" ? " (correct)" : r.correct === 0 || r.correct === "0" ? " (not correct)" : "");
      const cells = [r.trial, r.attempt, r.block || "", r.status, r.fault_code || "",
        fmt(r.tracking_rms_C, 3), fmt(r.tracking_max_C, 3), fmt(r.contact_s, 2),
        r.frames_lost === null || r.frames_lost === undefined ? "" : r.frames_lost, answer];
      for (const v of cells) {
        const td = document.createElement("td"); td.textContent = String(v); tr.appendChild(td);
      }
      if (r.words) tr.title = r.words;
      tr.addEventListener("click", () => pick(r, tr));
      body.appendChild(tr);
    }
  }

  function pick(r, tr) {
    for (const x of document.querySelectorAll("tr.picked")) x.classList.remove("picked");
    tr.classList.add("picked");
    const box = $("picked");
    box.hidden = false;
    $("picked-title").textContent = "Trial " + r.trial + ", attempt " + r.attempt + ": " + r.status +
      (r.fault_code ? " " + r.fault_code : "");
    const note = $("picked-fault");
    if (!r.trace_file) {
      note.hidden = false;
      note.textContent = (r.words ? r.words + "; " : "") + "no trace was written for this attempt";
      return;
    }
    fetch("trace?file=" + encodeURIComponent(r.trace_file)).then((resp) => {
      if (!resp.ok) throw new Error("HTTP " + resp.status);
      return resp.json();
    }).then((d) => {
      if (d.error) { note.hidden = false; note.textContent = d.error; return; }
      if (!picked) picked = window.monitorCharts.picked = makeCharts($("picked-temp"), $("picked-force"));
      draw(picked, d.trace, d.fault);
      note.hidden = !d.fault;
      if (d.fault) note.textContent = faultText(d.fault, "") + " (marked ● on the trace)";
      box.dataset.loaded = r.trace_file;
    }).catch((e) => { note.hidden = false; note.textContent = r.trace_file + ": " + e.message; });
  }

  function onMeta(m) {
    meta = m;
    $("session").textContent = "participant " + (m.participant || "?") + " · session " + (m.session || "?") +
      " · protocol " + (m.protocol || "?") + " · " + m.n_trials + " trials · " + (m.clock || "") + " clock · " + m.folder;
  }

  function onProblem(p) {
    const el = $("problem");
    el.hidden = !p;
    el.textContent = p || "";
  }

  function connect() {
    const es = new EventSource("events");
    es.onmessage = (ev) => {
      const msg = JSON.parse(ev.data);
      stats.updates += 1;
      stats.lastUpdateMs = performance.now();
      if (msg.meta) onMeta(msg.meta);
      if ("problem" in msg) onProblem(msg.problem);
      if (msg.rows) onRows(msg.rows_from, msg.rows);
      if (msg.trace) onTrace(msg.trace);
      if (msg.status) onStatus(msg.status);
    };
    es.onerror = () => {
      if (es.readyState === EventSource.CLOSED) {
        onProblem("the connection to the monitor was closed; reload the page when it runs again");
      } else {
        onProblem("the connection to the monitor was lost; trying again");
      }
    };
    es.onopen = () => onProblem(null);
  }
  connect();
})();
