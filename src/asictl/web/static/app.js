// The live board's page: a thin view over the REST API and its event stream (docs/web.md).
// Every text from the board or the program goes into the page as text (textContent,
// never innerHTML), so a hostile symbol table or comment cannot become markup.
"use strict";

const SLAVES = 31;
const WATCH_KEY = "asictl-watch";
const $ = (id) => document.getElementById(id);
const state = {
  session: { writable: false, logged_in: false, csrf: null, board: "" },
  status: null, names: new Map(), symbols: [], watch: loadWatch(), stream: null,
  program: null, programTimer: null, lastEvent: 0, uploadNote: "",
};

function el(tag, props = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(props)) {
    if (key === "class") node.className = value;
    else if (key === "text") node.textContent = value;
    else if (key.startsWith("data-") || key.startsWith("aria-")) node.setAttribute(key, value);
    else node[key] = value;
  }
  for (const child of children) node.append(child);
  return node;
}

function loadWatch() {
  try {
    const items = JSON.parse(localStorage.getItem(WATCH_KEY) || "[]");
    return Array.isArray(items) ? items.filter((i) => typeof i === "string").slice(0, 64) : [];
  } catch (_) { return []; }
}

function saveWatch() { localStorage.setItem(WATCH_KEY, JSON.stringify(state.watch)); }

// What each part was last drawn from: a part is drawn again only when that changed, so a
// board that changes every cycle does not replace the button under a user's click.
const drawn = new Map();

function changed(part, ...data) {
  const key = JSON.stringify(data);
  if (drawn.get(part) === key) return false;
  drawn.set(part, key);
  return true;
}

function setPill(id, text, kind) {
  const pill = $(id);
  pill.textContent = text;
  pill.dataset.state = kind;
}

// ---------------------------------------------------------------- the stream

function connect() {
  if (state.stream) state.stream.close();
  const query = new URLSearchParams();
  for (const name of state.watch) query.append("watch", name);
  const stream = new EventSource("/api/events" + (state.watch.length ? "?" + query : ""));
  state.stream = stream;
  stream.addEventListener("status", (message) => {
    const data = JSON.parse(message.data);
    setPill("link", "live", "ok");
    render(data);
  });
  stream.addEventListener("error", () => setPill("link", "disconnected: retrying", "gone"));
}

function render(data) {
  const status = data.status;
  state.status = status;
  state.names = new Map(Object.entries(status.symbols).map(([name, op]) => [op, name]));
  state.symbols = data.symbols || [];
  renderTop(status, data.events);
  renderSlaves(status);
  renderIO(status);
  renderNamed(status);
  renderForced(status);
  renderWatch(data.watch);
  renderEvents(data.events);
  renderNameList(status);
  if (state.program && state.program.identity !== status.program.identity) loadProgram();
}

function renderTop(status, events) {
  $("board").textContent = status.port;
  const gone = events.length && events[events.length - 1].text.startsWith("master gone");
  const phaseKind = gone ? "gone" : status.power_fail || !status.config_ok ? "error" : "ok";
  let phase = gone ? "master gone" : status.phase;
  if (status.power_fail) phase += ", AS-i power fail";
  else if (!status.config_ok) phase += ", configuration error";
  setPill("phase", phase, phaseKind);
  setPill("mode", status.mode + " mode", "info");
  const running = status.control_state === "running";
  const why = status.stop_reason ? " (" + status.stop_reason + ")" : "";
  if (status.held) setPill("control", "program " + status.held, "stopped");
  else setPill("control", "program " + status.control_state + why, running ? "running" : "stopped");
  const forced = status.forced ? status.forced.length : 0;
  setPill("forces", "FORCE " + forced, forced ? "some" : "none");
}

function slaveState(status, n) {
  const has = (list) => list && list.includes(n);
  if (status.wrong_profile.some((w) => w.slave === n)) return "wrong";
  if (has(status.lcs)) return "corrupted";
  if (has(status.las)) return "active";
  if (has(status.lps) && !has(status.lds)) return "missing";
  if (has(status.lds) && !has(status.lps)) return "unexpected";
  return "empty";
}

const LIST_WORDS = { LPS: "projected", LDS: "detected", LAS: "active", LCS: "corrupted",
                     LOS: "offline on error" };

function renderSlaves(status) {
  const grid = $("slaves");
  if (!grid.children.length) {
    for (let n = 1; n <= SLAVES; n++) {
      const tile = el("button", { type: "button", class: "tile", "data-slave": String(n),
                                  "aria-pressed": "false", role: "listitem" },
                      el("span", { class: "addr", text: String(n) }),
                      el("span", { class: "lists" }));
      tile.addEventListener("click", () => selectSlave(n));
      grid.append(tile);
    }
  }
  for (const tile of grid.children) {
    const n = Number(tile.dataset.slave);
    const lists = (status.slaves[String(n)] || { lists: [] }).lists;
    tile.dataset.state = slaveState(status, n);
    tile.lastChild.textContent = lists.map((l) => l[1]).join("");
    const words = lists.map((l) => LIST_WORDS[l] || l).join(", ") || "in no list";
    tile.setAttribute("aria-label", "slave " + n + ": " + words);
    tile.title = "slave " + n + ": " + words;
  }
  const selected = grid.querySelector('[aria-pressed="true"]');
  const shown = selected && selected.dataset.slave;
  if (shown && changed("slave", shown, status.slaves[shown], status.forced)) {
    showSlave(Number(selected.dataset.slave));
  }
}

function selectSlave(n) {
  for (const tile of $("slaves").children) {
    const on = Number(tile.dataset.slave) === n && tile.getAttribute("aria-pressed") !== "true";
    tile.setAttribute("aria-pressed", on ? "true" : "false");
  }
  const selected = $("slaves").querySelector('[aria-pressed="true"]');
  if (selected) showSlave(n); else $("slave-detail").replaceChildren();
}

function hex(value) { return value.toString(16).toUpperCase() + "h"; }

function profile(byte) { return "I/O " + hex(byte & 15) + ", ID " + hex(byte >> 4); }

function showSlave(n) {
  const data = state.status.slaves[String(n)];
  const detail = $("slave-detail");
  if (!data) {
    detail.replaceChildren(el("p", { text: "Slave " + n + " is in no list." }));
    return;
  }
  const rows = [
    ["lists", data.lists.map((l) => l + " (" + (LIST_WORDS[l] || l) + ")").join(", ")],
    ["projected configuration", profile(data.pcd)], ["detected configuration", profile(data.cdi)],
    ["parameters", "projected " + hex(data.pp) + ", actual " + hex(data.pi)],
    ["error counter", data.errors === null ? "not shown by this master" : String(data.errors)],
  ];
  const table = el("table", {}, el("caption", { text: "Slave " + n }));
  for (const [key, value] of rows) table.append(el("tr", {}, el("th", { text: key }), el("td", { text: value })));
  table.append(el("tr", {}, el("th", { text: "inputs" }), el("td", {}, bits("I", n, data.inputs))));
  table.append(el("tr", {}, el("th", { text: "outputs" }), el("td", {}, bits("Q", n, data.outputs))));
  const forms = detail.querySelector("div.forms");
  if (forms && forms.dataset.slave === String(n)) {
    detail.firstChild.replaceWith(table);  // the forms stay: what is typed, and the focus
    return;
  }
  detail.replaceChildren(table, el("div", { class: "forms", "data-slave": String(n) },
    slaveForm(n, "address", "New address", "Change address",
              (v) => "Give slave " + n + " the address " + v + "?"),
    slaveForm(n, "parameter", "Parameter (0..15)", "Write parameter",
              (v) => "Write parameter " + v + " to slave " + n + "? The permanent one stays until stored.")));
}

function slaveForm(n, what, label, action, question) {
  const id = "slave-" + what;
  const field = el("input", { id, inputMode: "numeric", autocomplete: "off" });
  const button = el("button", { type: "submit", text: action });
  writeControl(button);
  const form = el("form", { class: "row" },
                  el("label", { htmlFor: id, text: label }), field, button);
  form.addEventListener("submit", (event) => {
    event.preventDefault();
    const value = field.value.trim();
    const key = what === "address" ? "new" : "value";
    change("slaves/" + n + "/" + what, { [key]: value }, question(value));
  });
  return form;
}

function forcedOperands() {
  return new Set((state.status.forced || []).map((f) => f.operand));
}

function bits(letter, slave, value) {
  const forced = forcedOperands();
  const span = el("span", { class: "bits" });
  for (let b = 0; b < 4; b++) {
    const operand = letter + " " + slave + "." + b;
    const name = state.names.get(operand);
    const on = (value >> b) & 1;
    const isForced = forced.has(operand) || forced.has(letter + " " + slave);
    span.append(el("span", {
      class: "bit" + (on ? " on" : "") + (isForced ? " forced" : ""), text: String(on),
      title: operand + (name ? " " + name : "") + (isForced ? " (forced)" : ""),
      "aria-label": operand + (name ? " " + name : "") + " = " + on + (isForced ? ", forced" : ""),
    }));
  }
  return span;
}

function renderIO(status) {
  if (!changed("io", status.slaves, status.symbols, status.forced)) return;
  const body = $("io").tBodies[0];
  const rows = [];
  const numbers = Object.keys(status.slaves).map(Number).filter((n) => n >= 1).sort((a, b) => a - b);
  for (const n of numbers) {
    const data = status.slaves[String(n)];
    const names = [];
    for (const letter of ["I", "Q"]) {
      for (let b = 0; b < 4; b++) {
        const name = state.names.get(letter + " " + n + "." + b);
        if (name) names.push(name + " = " + letter + " " + n + "." + b);
      }
      const whole = state.names.get(letter + " " + n);
      if (whole) names.push(whole + " = " + letter + " " + n);
    }
    rows.push(el("tr", {}, el("td", { class: "num", text: String(n) }),
                 el("td", {}, bits("I", n, data.inputs)), el("td", {}, bits("Q", n, data.outputs)),
                 el("td", { text: names.join(", ") })));
  }
  if (!rows.length) rows.push(el("tr", {}, el("td", { colSpan: 4, class: "muted", text: "no slaves" })));
  body.replaceChildren(...rows);
}

function renderNamed(status) {
  if (!changed("named", state.symbols, status.timers, status.counters, status.symbols)) return;
  const rows = [];
  for (const row of state.symbols) {
    if (row.error || /^[IQ] /.test(row.operand)) continue;
    rows.push(el("tr", {}, el("td", { text: row.name }), el("td", { class: "mono", text: row.operand }),
                 el("td", { class: "num", text: String(row.value) })));
  }
  for (const timer of status.timers || []) {
    const name = state.names.get("T " + timer.number) || state.names.get("TV " + timer.number) || "";
    rows.push(el("tr", {}, el("td", { text: name }), el("td", { class: "mono", text: "T " + timer.number }),
                 el("td", { class: "num", text: timer.remaining_ms + " ms" + (timer.running ? ", running" : "") })));
  }
  for (const counter of status.counters || []) {
    const name = state.names.get("C " + counter.number) || state.names.get("CV " + counter.number) || "";
    rows.push(el("tr", {}, el("td", { text: name }), el("td", { class: "mono", text: "C " + counter.number }),
                 el("td", { class: "num", text: String(counter.value) })));
  }
  if (!rows.length) rows.push(el("tr", {}, el("td", { colSpan: 3, class: "muted", text: "none named, no timers or counters" })));
  $("named").tBodies[0].replaceChildren(...rows);
}

function renderForced(status) {
  if (!changed("forced", status.forced, state.session)) return;
  const rows = (status.forced || []).map((f) => {
    const label = f.symbol ? f.symbol + " (" + f.operand + ")" : f.operand;
    const release = el("button", { type: "button", text: "Release",
                                   "aria-label": "Release the force of " + label });
    release.addEventListener("click", () => change("unforce", { operands: [f.operand] },
      "Release the force of " + label + "? The program decides its value again."));
    writeControl(release);
    return el("tr", {}, el("td", { text: label }), el("td", { class: "num", text: String(f.value) }),
              el("td", {}, release));
  });
  if (!rows.length) rows.push(el("tr", {}, el("td", { colSpan: 3, class: "muted", text: "nothing forced" })));
  $("forced").tBodies[0].replaceChildren(...rows);
}

function renderWatch(rows) {
  if (!changed("watch", rows, state.watch)) return;
  const body = $("watch").tBodies[0];
  const shown = state.watch.map((name, i) => {
    const row = rows[i] && rows[i].name === name ? rows[i] : { name };
    const remove = el("button", { type: "button", text: "Remove",
                                  "aria-label": "Remove " + name + " from the watch list" });
    remove.addEventListener("click", () => {
      state.watch.splice(i, 1);
      saveWatch();
      connect();
    });
    const value = row.error ? row.error : row.value === undefined ? "…" : String(row.value);
    return el("tr", { "data-watch": name }, el("td", { text: name }),
              el("td", { class: "mono", text: row.operand || "" }),
              el("td", { class: row.error ? "muted" : "num", text: value }), el("td", {}, remove));
  });
  if (!shown.length) shown.push(el("tr", {}, el("td", { colSpan: 4, class: "muted", text: "add a name above" })));
  body.replaceChildren(...shown);
}

function renderEvents(events) {
  const list = $("events");
  for (const event of events) {
    if (event.id <= state.lastEvent) continue;
    state.lastEvent = event.id;
    const when = new Date(event.time * 1000);
    list.prepend(el("li", {}, el("time", { text: when.toLocaleTimeString() }), event.text));
  }
  while (list.children.length > 100) list.lastChild.remove();
}

function renderNameList(status) {
  const names = Object.keys(status.symbols).sort();
  const list = $("names-list");
  if (list.children.length === names.length) return;
  list.replaceChildren(...names.map((name) => el("option", { value: name })));
}

// ---------------------------------------------------------------- changes

function writeControl(button) {
  button.disabled = !state.session.writable;
  if (!state.session.writable) button.title = "read-only: the server was started without --http-writable";
}

function answer(text, isError) {
  $("answer").textContent = text;
  $("answer").className = isError ? "error" : "";
}

function confirmChange(text) {
  const dialog = $("confirm");
  $("confirm-text").textContent = text;
  return new Promise((resolve) => {
    dialog.addEventListener("close", () => resolve(dialog.returnValue === "ok"), { once: true });
    dialog.returnValue = "cancel";
    dialog.showModal();
    $("confirm-cancel").focus();
  });
}

async function api(path, body) {
  const headers = { "Content-Type": "application/json" };
  if (state.session.csrf) headers["X-CSRF-Token"] = state.session.csrf;
  const response = await fetch(path, { method: "POST", headers, credentials: "same-origin",
                                       body: JSON.stringify(body || {}) });
  let data = {};
  try { data = await response.json(); } catch (_) { data = { error: response.statusText }; }
  return { ok: response.ok, status: response.status, data };
}

async function change(action, body, question) {
  if (!state.session.writable) { answer("This web server is read-only.", true); return; }
  if (!state.session.logged_in) { openLogin(); return; }
  if (!(await confirmChange(question))) { answer("Cancelled: nothing changed.", false); return; }
  const result = await api("/api/" + action, body);
  if (result.ok) answer(action + ": done", false);
  else {
    answer(result.data.error || "refused", true);
    if (result.status === 401) { state.session.logged_in = false; showAccess(); }
  }
}

async function describe(text) {
  // "Start=1" -> "Start (I 1.0) to 1", asking the board what the name stands for
  const at = text.lastIndexOf("=");
  if (at < 1) return null;
  const name = text.slice(0, at).trim(), value = text.slice(at + 1).trim();
  const response = await fetch("/api/operands/" + encodeURIComponent(name));
  const data = await response.json();
  if (!response.ok) { answer(data.error, true); return null; }
  const label = data.symbol ? data.symbol + " (" + data.operand + ")" : data.operand;
  return { label, value };
}

async function submitChange(action) {
  const text = $("change-text").value.trim();
  const what = await describe(text);
  if (!what) { if (!$("answer").textContent) answer("Write OPERAND=VALUE, e.g. Start=1", true); return; }
  const question = action === "force"
    ? "Force " + what.label + " to " + what.value + "? It stays so, whatever the program does, until released."
    : "Write " + what.value + " to " + what.label + "?";
  await change(action, { assignments: [text] }, question);
}

// ---------------------------------------------------------------- program view

async function loadProgram() {
  const response = await fetch("/api/program");
  state.program = await response.json();
  $("program-note").textContent = state.program.note || "";
  const rows = state.program.lines.map((line) => {
    if (line.line === 0) return el("tr", { class: "file" }, el("td", { colSpan: 6, text: line.file }));
    const operand = line.operand ? line.operand + (line.symbol ? " (" + line.symbol + ")" : "") : "";
    return el("tr", { class: line.code ? "code" : "nocode", "data-line": line.file + ":" + line.line },
              el("td", { class: "num", text: String(line.line) }),
              el("td", { class: "src", text: line.text === null ? "" : line.text }),
              el("td", { class: "num rlo" }), el("td", { class: "num accu1" }),
              el("td", { class: "num accu2" }), el("td", { class: "operand", text: operand, "data-label": operand }));
  });
  $("program").tBodies[0].replaceChildren(...rows);
}

async function loadLines() {
  const response = await fetch("/api/program/lines");
  const data = await response.json();
  if (!response.ok) { $("program-note").textContent = data.error; return; }
  // the refresh keeps the upload's note: it is the answer to the user's last click
  $("program-note").textContent =
    data.note || (state.program && state.program.note) || state.uploadNote || "";
  const body = $("program").tBodies[0];
  for (const line of data.lines) {
    const row = body.querySelector('[data-line="' + CSS.escape(line.file + ":" + line.line) + '"]');
    if (!row) continue;
    row.classList.toggle("idle", !line.ran);
    row.querySelector(".rlo").textContent = line.ran ? String(line.rlo) : "-";
    row.querySelector(".accu1").textContent = line.ran ? String(line.accu1) : "-";
    row.querySelector(".accu2").textContent = line.ran ? String(line.accu2) : "-";
    const operand = row.querySelector(".operand");
    const value = line.ran && line.operand !== null ? " = " + line.operand : "";
    operand.textContent = operand.dataset.label + value;
  }
}

async function toggleProgram() {
  const button = $("program-toggle");
  const open = button.getAttribute("aria-expanded") !== "true";
  button.setAttribute("aria-expanded", String(open));
  $("program-view").hidden = !open;
  clearInterval(state.programTimer);
  if (!open) return;
  await loadProgram();
  await loadLines();
  state.programTimer = setInterval(loadLines, 500);
}

async function saveProgram() {
  // the main file as 'asictl upload' writes it, saved by the browser
  const response = await fetch("/api/upload");
  const data = await response.json();
  if (!response.ok) { $("program-note").textContent = data.error; return; }
  const main = data.files[0];
  const bytes = Uint8Array.from(atob(main.base64), (c) => c.charCodeAt(0));
  const link = el("a", { href: URL.createObjectURL(new Blob([bytes])), download: main.name });
  link.click();
  URL.revokeObjectURL(link.href);
  state.uploadNote = "Uploaded " + main.name + " (" + data.identity + ")" +
    (data.files.length > 1 ? "; its other files: asictl upload" : "");
  $("program-note").textContent = state.uploadNote;
}

// ---------------------------------------------------------------- access

function showAccess() {
  const s = state.session;
  $("access-text").textContent = !s.writable ? "read-only" : s.logged_in ? "logged in: changes allowed" : "view only: log in to change";
  $("login-open").hidden = !s.writable || s.logged_in;
  $("logout").hidden = !s.logged_in;
  for (const id of ["force-button", "write-button", "release-all", "start", "stop", "mode-protected",
                    "mode-configuration", "store-configuration", "store-parameters"]) writeControl($(id));
  for (const button of $("forced").querySelectorAll("button")) writeControl(button);
}

async function loadSession() {
  const response = await fetch("/api/session", { credentials: "same-origin" });
  state.session = await response.json();
  showAccess();
}

function openLogin() {
  $("login-error").textContent = "";
  $("token").value = "";
  $("login").showModal();
  $("token").focus();
}

async function login(event) {
  if (event.submitter && event.submitter.value === "cancel") return;
  event.preventDefault();
  const result = await api("/api/login", { token: $("token").value });
  if (!result.ok) { $("login-error").textContent = result.data.error || "refused"; return; }
  $("login").close();
  await loadSession();
  answer("Logged in: changes are allowed, each after a confirmation.", false);
}

// ---------------------------------------------------------------- start

function start() {
  $("watch-form").addEventListener("submit", (event) => {
    event.preventDefault();
    const name = $("watch-name").value.trim();
    if (name && !state.watch.includes(name) && state.watch.length < 64) {
      state.watch.push(name);
      saveWatch();
      connect();
    }
    $("watch-name").value = "";
  });
  $("change-form").addEventListener("submit", (event) => { event.preventDefault(); submitChange("force"); });
  $("write-button").addEventListener("click", () => submitChange("write"));
  $("release-all").addEventListener("click", () => {
    const count = state.status && state.status.forced ? state.status.forced.length : 0;
    change("unforce", { all: true }, "Release all " + count + " forces? The program decides their values again.");
  });
  $("start").addEventListener("click", () => change("start", {}, "Start the control program on board " + state.session.board + "?"));
  $("stop").addEventListener("click", () => change("stop", {}, "Stop the control program on board " + state.session.board + "? The master goes on as a plain AS-i master."));
  for (const mode of ["protected", "configuration"]) {
    $("mode-" + mode).addEventListener("click", () => change("mode", { mode },
      "Switch board " + state.session.board + " to " + mode + " mode?"));
  }
  $("store-configuration").addEventListener("click", () => change("store", { what: "configuration" },
    "Store the detected slaves as the projected configuration (LPS, PCD) of board " + state.session.board + "?"));
  $("store-parameters").addEventListener("click", () => change("store", { what: "parameters" },
    "Store the actual parameters (PI) as the permanent ones (PP) of board " + state.session.board + "?"));
  $("program-toggle").addEventListener("click", toggleProgram);
  $("upload").addEventListener("click", saveProgram);
  $("login-open").addEventListener("click", openLogin);
  $("login-form").addEventListener("submit", login);
  $("logout").addEventListener("click", async () => { await api("/api/logout"); await loadSession(); });
  loadSession().then(connect);
}

start();
