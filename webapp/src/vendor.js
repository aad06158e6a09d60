// The three.js build the page uses: the core and the two add-ons it needs, bundled by
// build.mjs into usdworld/serve/static/vendor/three.bundle.js (shipped; no CDN).
export * from 'three';
export { OrbitControls } from 'three/addons/controls/OrbitControls.js';
export { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
