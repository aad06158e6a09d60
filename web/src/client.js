// Page code for the usdworld browser client test: loads an export with the real three.js
// loaders (bundled, no CDN) and reports what three.js made of it.
//
// window.usdworldLoad(url, kind) -> { meshCount, triangles, bboxMin, bboxMax, names, extras, ... }
//   kind: "gltf" (GLTFLoader) or "usdz" (USDLoader; USDZLoader is its deprecated alias since r179)

import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { USDLoader } from 'three/examples/jsm/loaders/USDLoader.js';

const canvas = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
renderer.setSize(canvas.width, canvas.height, false);

function summarise(root) {
  root.updateMatrixWorld(true);
  let meshCount = 0;
  let triangles = 0;
  const names = [];
  const extras = {};
  const colors = {};
  root.traverse((obj) => {
    if (obj.userData && obj.userData.usdPath && Object.keys(obj.userData).length > 1) {
      extras[obj.userData.usdPath] = obj.userData;
    }
    if (!obj.isMesh) return;
    meshCount += 1;
    names.push(obj.name);
    const geo = obj.geometry;
    const count = geo.index ? geo.index.count : geo.attributes.position.count;
    triangles += count / 3;
    const mat = Array.isArray(obj.material) ? obj.material[0] : obj.material;
    if (mat && mat.color) colors[mat.name || obj.name] = mat.color.toArray();
  });
  const box = new THREE.Box3().setFromObject(root, true);
  return {
    meshCount,
    triangles,
    bboxMin: box.min.toArray(),
    bboxMax: box.max.toArray(),
    names,
    extras,
    colors,
  };
}

function render(root, bboxMin, bboxMax) {
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x87a5c0);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x404040, 2.0));
  const sun = new THREE.DirectionalLight(0xffffff, 2.0);
  sun.position.set(30, 60, 20);
  scene.add(sun);
  scene.add(root);
  const min = new THREE.Vector3(...bboxMin);
  const max = new THREE.Vector3(...bboxMax);
  const centre = min.clone().add(max).multiplyScalar(0.5);
  const size = max.clone().sub(min).length();
  const camera = new THREE.PerspectiveCamera(50, canvas.width / canvas.height, 0.05, size * 4 + 10);
  // glTF/three.js is Y up; usdworld's X forward becomes three's +X: look along +X from behind
  camera.position.set(min.x - 2, 4, 0);
  camera.lookAt(centre.x, 0, 0);
  renderer.render(scene, camera);
  const gl = renderer.getContext();
  return { drawCalls: renderer.info.render.calls, webgl: gl ? gl.getParameter(gl.VERSION) : null };
}

async function load(url, kind) {
  if (kind === 'gltf') {
    const gltf = await new GLTFLoader().loadAsync(url);
    return gltf.scene;
  }
  if (kind === 'usdz') {
    return await new USDLoader().loadAsync(url);
  }
  throw new Error(`unknown kind ${kind}`);
}

window.usdworldLoad = async (url, kind) => {
  const root = await load(url, kind);
  const summary = summarise(root);
  summary.render = render(root, summary.bboxMin, summary.bboxMax);
  summary.threeRevision = THREE.REVISION;
  return summary;
};
window.usdworldReady = true;
