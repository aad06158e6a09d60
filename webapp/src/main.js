// The page of `usdworld serve`: object list, selection details with provenance, edit
// actions, undo / redo, the source photo (a multi-view world: a view picker, the chosen
// view's camera and photo), and live sync with the edits layer on disk.
// Every edit is a POST to the server, which runs it through usdworld's editing engine;
// a refusal comes back with the rule's reason and is shown in the message line.

import { ApiError, getBinary, getJSON, post, token, withToken } from './api.js';
import { Viewer } from './viewer.js';

const POLL_MS = 1000;
const $ = (id) => document.getElementById(id);

const state = {
  world: null, // last /api/world
  version: null, // version of state.world
  sceneVersion: null, // version of the GLB shown
  selected: null,
  placing: false,
  busy: 0,
  refreshing: null,
  refreshAgain: false,
  lastMessage: '',
  expected: null, // version an edit of ours produced
  view: null, // the chosen view of a multi-view world (null: the world's source camera)
};

const viewer = new Viewer($('viewport'), $('canvas'));
viewer.heightOf = (name) => {
  const o = objectByName(name);
  return o ? o.position_m[2] : 0;
};

// --- helpers ---------------------------------------------------------------------------

function objectByName(name) {
  return state.world ? state.world.objects.find((o) => o.name === name) : undefined;
}

function fmt(value, digits = 2) {
  if (value === null || value === undefined) return '–';
  if (typeof value === 'number') return value.toFixed(digits);
  if (Array.isArray(value)) return value.map((v) => fmt(v, digits)).join(', ');
  if (typeof value === 'boolean') return value ? 'yes' : 'no';
  return String(value);
}

function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'class') node.className = v;
    else if (k === 'dataset') Object.assign(node.dataset, v);
    else node.setAttribute(k, v);
  }
  for (const child of children) node.append(child instanceof Node ? child : document.createTextNode(String(child)));
  return node;
}

function showMessage(text, kind = 'info') {
  const m = $('message');
  m.textContent = text;
  m.dataset.kind = kind;
  state.lastMessage = text;
}

function fillSelect(select, values, selected) {
  select.replaceChildren(...values.map((v) => el('option', { value: v }, v || '(none)')));
  if (selected !== undefined && values.includes(selected)) select.value = selected;
}

// --- loading and live sync ---------------------------------------------------------------

/** The chosen view of a multi-view world ({name, camera, photo}), or null. */
function chosenView(world = state.world) {
  return (world && world.views.find((v) => v.name === state.view)) || null;
}

/** The camera to look through: the chosen view's, else the world's source camera. */
function viewCamera(world = state.world) {
  const view = chosenView(world);
  return view ? view.camera : world.camera;
}

/** Show the chosen view's photo (or the source photo) as the backdrop and in the photo panel. */
function showPhoto() {
  const view = chosenView();
  const has = view ? view.photo : state.world.photo;
  const url = view ? withToken(`/api/photo?view=${encodeURIComponent(view.name)}`) : withToken('/api/photo');
  $('photo-wrap').hidden = !has;
  $('no-photo').hidden = has;
  $('toggle-backdrop').disabled = !has;
  if (has) {
    $('photo').src = url;
    viewer.setBackdrop(url, $('toggle-backdrop').checked);
  } else {
    $('photo').removeAttribute('src');
    viewer.setBackdrop(null, false);
  }
}

/** Look through the view ``name`` of a multi-view world, its photo behind. */
function chooseView(name) {
  state.view = name;
  $('view-picker').value = name;
  viewer.setSourceCamera(viewCamera());
  showPhoto();
  if (state.selected) renderDetails();
  document.body.dataset.view = name;
}

async function loadWorld() {
  const world = await getJSON('/api/world');
  const first = state.world === null;
  const cameraChanged = !first && JSON.stringify(viewCamera(world)) !== JSON.stringify(viewCamera());
  state.world = world;
  if (cameraChanged) viewer.setSourceCamera(viewCamera()); // the world was rebuilt
  if (first) {
    $('world-name').textContent = `${world.world.name}/${world.world.root.split('/').pop()}`;
    $('world-name').title = world.world.root;
    if (world.views.length > 1) {
      fillSelect($('view-picker'), world.views.map((v) => v.name));
      $('view-picker-wrap').hidden = false;
      chooseView(world.views[0].name);
    } else {
      viewer.setSourceCamera(world.camera);
      showPhoto();
    }
    if (!(chosenView() ? chosenView().photo : world.photo)) {
      $('toggle-photo-panel').checked = false;
      $('photo-panel').hidden = true;
    }
    fillAddClasses();
  }
  if (world.version !== state.sceneVersion) {
    const { buffer, version } = await getBinary('/api/scene.glb');
    await viewer.loadScene(buffer);
    state.sceneVersion = version;
  }
  state.version = world.version;
  if (state.sceneVersion !== world.version) state.refreshAgain = true; // changed between the two reads
  renderAll();
}

/** Re-read the world (one at a time; a request during a refresh schedules one more). */
function refresh() {
  if (state.refreshing) {
    state.refreshAgain = true;
    return state.refreshing;
  }
  state.refreshing = (async () => {
    try {
      do {
        state.refreshAgain = false;
        await loadWorld();
      } while (state.refreshAgain);
    } finally {
      state.refreshing = null;
    }
  })();
  return state.refreshing;
}

async function poll() {
  try {
    if (!state.busy && !viewer._gesture) {
      const { version } = await getJSON('/api/version');
      // Our own edits set state.version / state.expected before `busy` drops: only a
      // version nobody here asked for is someone else's edit.
      if (!state.busy && version !== state.version && version !== state.expected) {
        await refresh();
        showMessage('The world changed on disk (edited elsewhere); the view is up to date.', 'info');
      }
    }
  } catch (error) {
    showMessage(`Lost the server: ${error.message}`, 'error');
  } finally {
    setTimeout(poll, POLL_MS);
  }
}

// --- rendering the panels ------------------------------------------------------------------

function renderAll() {
  renderList();
  renderDetails();
  renderHistory();
  $('btn-undo').disabled = !state.world.can_undo;
  $('btn-redo').disabled = !state.world.can_redo;
  document.body.dataset.version = state.version;
}

function renderList() {
  const objects = state.world.objects;
  const active = objects.filter((o) => o.active).length;
  const deleted = objects.length - active;
  $('object-count').textContent = `${active} objects` + (deleted ? `, ${deleted} deleted` : '');
  const rows = objects.map((o) => {
    const row = el(
      'tr',
      { dataset: { name: o.name }, class: [o.active ? '' : 'deleted', o.name === state.selected ? 'selected' : ''].join(' ').trim() },
      el('td', {}, o.class),
      el('td', {}, o.name),
      el('td', { class: 'num' }, fmt(o.depth_m, 1)),
      el('td', { class: 'method', title: o.depth_method || '' }, o.depth_method || '–'),
      el('td', {}, o.status + (o.color ? ` ${o.color}` : '')),
    );
    row.addEventListener('click', () => select(o.name, true));
    return row;
  });
  $('object-list').tBodies[0].replaceChildren(...rows);
}

function dl(target, pairs) {
  target.replaceChildren(...pairs.flatMap(([k, v]) => [el('dt', {}, k), el('dd', {}, v)]));
}

function renderDetails() {
  const o = objectByName(state.selected);
  const panel = $('details');
  if (!o) {
    panel.hidden = true;
    $('photo-bbox').hidden = true;
    return;
  }
  panel.hidden = false;
  $('details-title').textContent = `${o.name} · ${o.class}${o.variant ? ` (${o.variant})` : ''}`;
  const p = o.provenance;
  dl($('details-facts'), [
    ['status', o.status + (o.color ? ` · colour ${o.color}` : '')],
    ['position m', fmt(o.position_m)],
    ['yaw °', fmt(o.yaw_deg, 1)],
    ['scale', fmt(o.scale, 3)],
    ['size l×w m', fmt(o.size_lw_m)],
    ['surface', o.surface],
  ]);
  const scene = state.world.scene;
  dl($('details-provenance'), [
    ['depth m', `${fmt(p.depth_m)} (${p.depth_method || '–'})`],
    ['DLT error', `${fmt(scene.dlt_rms_px, 3)} px RMS (${scene.dlt_source || '–'})`],
    ['scale', `${fmt(p.scale_factor, 3)} (measured ${fmt(p.scale_measured, 3)})`],
    ['yaw source', p.yaw_source || '–'],
    ['confidence', fmt(p.confidence)],
    ['collision shift m', fmt(p.collision_displacement_m)],
    ['image box px', fmt(p.image_bbox_px, 0)],
    ['ground contact px', fmt(p.contact_px, 1)],
    ['bottom cut / hidden', `${fmt(p.bottom_truncated)} / ${fmt(p.bottom_occluded)}`],
    ['source class', p.source_class || '–'],
  ]);
  $('depth-cues').tBodies[0].replaceChildren(
    ...(p.depth_cues.length
      ? p.depth_cues.map((c) => el('tr', {}, el('td', {}, c.name), el('td', { class: 'num' }, fmt(c.depth_m)), el('td', { class: 'num' }, fmt(c.sigma_m))))
      : [el('tr', {}, el('td', { colspan: '3', class: 'muted' }, 'no image evidence (added by hand)'))]),
  );
  // actions
  for (const id of ['yaw-input', 'btn-rotate', 'btn-rot-left', 'btn-rot-right', 'replace-class', 'replace-variant', 'btn-replace', 'restyle-color', 'btn-restyle', 'btn-delete']) {
    $(id).disabled = !o.active;
  }
  $('btn-reset').disabled = o.status === 'base';
  if (document.activeElement !== $('yaw-input')) $('yaw-input').value = o.yaw_deg.toFixed(1);
  if (o.color) $('restyle-color').value = o.color;
  const options = state.world.classes.replace_with[o.class] || {};
  const classes = Object.keys(options);
  const keep = classes.includes($('replace-class').value) && $('replace-class').dataset.for === o.name;
  fillSelect($('replace-class'), classes, keep ? $('replace-class').value : o.class);
  $('replace-class').dataset.for = o.name;
  fillReplaceVariants();
  // the box in the photo shown: the chosen view's (none when that view did not see it)
  const box = state.view ? p.view_bboxes_px[state.view] : p.image_bbox_px;
  const size = scene.image_size_px;
  const bbox = $('photo-bbox');
  if (box && size && (box[2] > box[0] || box[3] > box[1])) {
    bbox.hidden = false;
    bbox.style.left = `${(100 * box[0]) / size[0]}%`;
    bbox.style.top = `${(100 * box[1]) / size[1]}%`;
    bbox.style.width = `${(100 * (box[2] - box[0])) / size[0]}%`;
    bbox.style.height = `${(100 * (box[3] - box[1])) / size[1]}%`;
  } else {
    bbox.hidden = true;
  }
}

function fillReplaceVariants() {
  const o = objectByName(state.selected);
  if (!o) return;
  const cls = $('replace-class').value;
  let variants = (state.world.classes.replace_with[o.class] || {})[cls] || [];
  if (cls === o.class) variants = variants.filter((v) => v !== o.variant); // same class: another variant
  fillSelect($('replace-variant'), variants);
  $('btn-replace').disabled = !o.active || (cls === o.class && variants.length === 0);
}

function fillAddClasses() {
  const classes = state.world.classes;
  fillSelect($('add-class'), classes.addable, classes.addable.includes('car') ? 'car' : undefined);
  fillAddVariants();
}

function fillAddVariants() {
  const classes = state.world.classes;
  const cls = $('add-class').value;
  fillSelect($('add-variant'), classes.variants[cls] || [], classes.default_variant[cls]);
}

function renderHistory() {
  const history = state.world.history;
  $('history-count').textContent = `${state.world.history_length} edit(s)`;
  $('history').replaceChildren(
    ...history
      .slice(-12)
      .map((h) =>
        el('li', { value: String(h.step), class: h.forced ? 'forced' : '' }, `${h.op} ${h.name}${h.forced ? ' (forced)' : ''}`),
      ),
  );
}

// --- selection and edits ----------------------------------------------------------------------

function select(name, fromList = false) {
  state.selected = name;
  viewer.select(name);
  renderList();
  renderDetails();
  if (fromList === false && name) {
    const row = document.querySelector(`#object-list tr[data-name="${CSS.escape(name)}"]`);
    if (row) row.scrollIntoView({ block: 'nearest', inline: 'start' });
  }
}

async function edit(op, body, { onRefused } = {}) {
  state.busy += 1;
  try {
    const res = await post(op, body);
    if (res.body && res.body.version) state.expected = res.body.version;
    if (res.ok) {
      showMessage(res.body.message || `${op} done`, 'ok');
      await refresh();
    } else {
      if (onRefused) onRefused();
      const reasons = res.body.refused ? res.body.reasons.join('; ') : '';
      showMessage(res.body.refused ? `Refused: ${op} ${body.name || body.class || ''} — ${reasons}` : `Error: ${res.body.error}`, 'error');
    }
    return res;
  } catch (error) {
    if (onRefused) onRefused();
    showMessage(`Error: ${error.message}`, 'error');
    return { ok: false };
  } finally {
    state.busy -= 1;
  }
}

viewer.addEventListener('pick', (e) => select(e.detail.name));
viewer.addEventListener('drop', async (e) => {
  const { name, dx, dy } = e.detail;
  const o = objectByName(name);
  if (!o) return;
  select(name);
  const to = [o.position_m[0] + dx, o.position_m[1] + dy];
  await edit('move', { name, to }, { onRefused: () => viewer.setOffset(name, 0, 0) });
});
viewer.addEventListener('place', async (e) => {
  setPlacing(false);
  const cls = $('add-class').value;
  const res = await edit('add', { class: cls, at: [e.detail.x, e.detail.y], variant: $('add-variant').value || null });
  if (res.ok) select(res.body.name);
});
viewer.addEventListener('view', (e) => {
  $('btn-source-view').classList.toggle('active', e.detail.source);
});

function setPlacing(on) {
  state.placing = on;
  viewer.setPlacing(on);
  $('btn-add').classList.toggle('active', on);
  const hint = $('mode-hint');
  hint.hidden = !on;
  hint.textContent = on ? `Click the ground to place a ${$('add-class').value} (Esc cancels)` : '';
}

function rotateBy(delta) {
  const o = objectByName(state.selected);
  if (o) edit('rotate', { name: o.name, yaw_deg: o.yaw_deg + delta });
}

$('btn-source-view').addEventListener('click', () => viewer.sourceView());
$('view-picker').addEventListener('change', (e) => chooseView(e.target.value));
$('toggle-backdrop').addEventListener('change', (e) => viewer.setBackdrop(null, e.target.checked));
$('overlay-opacity').addEventListener('input', (e) => viewer.setOverlayOpacity(Number(e.target.value)));
$('toggle-photo-panel').addEventListener('change', (e) => {
  $('photo-panel').hidden = !e.target.checked;
});
$('btn-undo').addEventListener('click', () => edit('undo', { steps: 1 }));
$('btn-redo').addEventListener('click', () => edit('redo', { steps: 1 }));
$('btn-rotate').addEventListener('click', () => {
  const o = objectByName(state.selected);
  const yaw = Number($('yaw-input').value);
  if (o && Number.isFinite(yaw)) edit('rotate', { name: o.name, yaw_deg: yaw });
});
$('btn-rot-left').addEventListener('click', () => rotateBy(-15));
$('btn-rot-right').addEventListener('click', () => rotateBy(15));
$('replace-class').addEventListener('change', fillReplaceVariants);
$('btn-replace').addEventListener('click', () => {
  const o = objectByName(state.selected);
  if (o) edit('replace', { name: o.name, with: $('replace-class').value, variant: $('replace-variant').value || null });
});
$('btn-restyle').addEventListener('click', () => {
  const o = objectByName(state.selected);
  if (o) edit('restyle', { name: o.name, color: $('restyle-color').value });
});
$('btn-delete').addEventListener('click', () => {
  const o = objectByName(state.selected);
  if (o) edit('delete', { name: o.name });
});
$('btn-reset').addEventListener('click', () => {
  const o = objectByName(state.selected);
  if (o) edit('reset', { name: o.name });
});
$('add-class').addEventListener('change', () => {
  fillAddVariants();
  if (state.placing) setPlacing(true);
});
$('btn-add').addEventListener('click', () => setPlacing(!state.placing));

document.addEventListener('keydown', (e) => {
  const typing = ['INPUT', 'SELECT', 'TEXTAREA'].includes(document.activeElement?.tagName);
  if (e.key === 'Escape') {
    if (state.placing) setPlacing(false);
    else select(null);
  } else if ((e.key === 'Delete' || e.key === 'Backspace') && !typing && state.selected) {
    e.preventDefault();
    $('btn-delete').click();
  } else if ((e.ctrlKey || e.metaKey) && e.key.toLowerCase() === 'z' && !typing) {
    e.preventDefault();
    (e.shiftKey ? $('btn-redo') : $('btn-undo')).click();
  } else if ((e.ctrlKey || e.metaKey) && e.key.toLowerCase() === 'y' && !typing) {
    e.preventDefault();
    $('btn-redo').click();
  }
});

// Hooks for the end-to-end test (and for curious users in the console).
window.usdworld = { state, viewer, select, refresh, ready: false };

(async () => {
  if (!token) {
    showMessage('No session token in the URL: open the exact URL that `usdworld serve` printed.', 'error');
    return;
  }
  try {
    await refresh();
    const n = state.world.objects.filter((o) => o.active).length;
    showMessage(`Loaded ${n} objects. Drag one to move it; click to select.`, 'info');
    window.usdworld.ready = true;
  } catch (error) {
    const hint = error instanceof ApiError && error.status === 401 ? ' (wrong token: open the URL usdworld serve printed)' : '';
    showMessage(`Cannot load the world: ${error.message}${hint}`, 'error');
    return;
  }
  setTimeout(poll, POLL_MS);
})();
