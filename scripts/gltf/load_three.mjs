// Loads a glTF/GLB file with three.js's GLTFLoader headless in Node (no browser, no WebGL) and
// prints what three.js made of it as JSON: materials (colour, emissive, emissiveIntensity, ior,
// dispersion, transmission, the lumifit extras), lights, cameras, animation tracks, and — with
// the KHR_animation_pointer plugin (@needle-tools/three-animation-pointer) registered — the
// emission three.js computes at the times given, by playing the clip in an AnimationMixer.
// Versions pinned in package.json / package-lock.json; install with `npm ci` in this folder.
//
//   usage: node scripts/gltf/load_three.mjs FILE.gltf|FILE.glb [t_s,t_s,…]
import { readFile } from "node:fs/promises";
import * as THREE from "three";
import { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";
import { GLTFAnimationPointerExtension } from "@needle-tools/three-animation-pointer";

const [file, timesArg] = process.argv.slice(2);
if (!file) {
  console.error("usage: node load_three.mjs FILE.gltf|FILE.glb [t_s,t_s,…]");
  process.exit(2);
}
// FileLoader (used for the data: URI buffer) reports progress with the browser's ProgressEvent.
globalThis.ProgressEvent ??= class ProgressEvent extends Event {
  constructor(type, init = {}) {
    super(type);
    Object.assign(this, init);
  }
};
const bytes = await readFile(file);
const data = file.toLowerCase().endsWith(".glb")
  ? bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength)
  : bytes.toString("utf8");
const loader = new GLTFLoader();
loader.register((parser) => new GLTFAnimationPointerExtension(parser));
const gltf = await new Promise((resolve, reject) => loader.parse(data, "", resolve, reject));

const materials = new Map();
const lights = [];
const cameras = [];
const lightObjects = [];
const root = gltf.scene ?? new THREE.Group(); // a material-only export has no scene
root.traverse((o) => {
  if (o.isMesh) materials.set(o.material.uuid, o.material);
  if (o.isLight) {
    lightObjects.push(o);
    lights.push({ type: o.type, intensity: o.intensity });
  }
  if (o.isCamera) cameras.push({ type: o.type, fov_deg: o.fov });
});
// Materials not on any mesh (a material-only export) are reached through the parser.
for (let i = 0; i < (gltf.parser.json.materials ?? []).length; i++) {
  const m = await gltf.parser.getDependency("material", i);
  if (![...materials.values()].some((x) => x.name === m.name)) materials.set(m.uuid, m);
}
const describe = (m) => ({
  name: m.name,
  type: m.type,
  color: m.color?.toArray(),
  emissive: m.emissive?.toArray(),
  emissiveIntensity: m.emissiveIntensity,
  metalness: m.metalness,
  roughness: m.roughness,
  ior: m.ior,
  dispersion: m.dispersion,
  transmission: m.transmission,
  thickness: m.thickness,
  extras: Object.keys(m.userData ?? {}),
});
const out = {
  three: THREE.REVISION,
  materials: [...materials.values()].map(describe),
  lights,
  cameras,
  animations: gltf.animations.map((a) => ({
    name: a.name,
    duration_s: a.duration,
    tracks: a.tracks.map((t) => ({ name: t.name, keys: t.times.length })),
  })),
};
// Emission = emissive × emissiveIntensity (linear RGB) of the first mesh's material over time.
if (timesArg && gltf.animations.length > 0) {
  const mixer = new THREE.AnimationMixer(root);
  const action = mixer.clipAction(gltf.animations[0]);
  // Play once and hold the last key (the default LoopRepeat wraps t = duration back to 0).
  action.setLoop(THREE.LoopOnce, 1);
  action.clampWhenFinished = true;
  action.play();
  const mesh = [];
  root.traverse((o) => o.isMesh && mesh.push(o));
  const m = mesh[0]?.material;
  out.emission = timesArg.split(",").map(Number).map((t) => {
    mixer.setTime(t);
    return {
      t_s: t,
      rgb: m.emissive.toArray().map((c) => c * m.emissiveIntensity),
      light_intensity: lightObjects[0]?.intensity ?? null,
    };
  });
}
console.log(JSON.stringify(out, null, 1));
