// World joint positions of a .glb as three.js reads it: GLTFLoader, its first animation in an AnimationMixer,
// each key time in turn; joints are the skin's, by node index, with the file's node names.
// usage: node gltf_positions.mjs FILE.glb OUT.json   → {names, fps, frames, positions: [frame][joint][xyz], meshes}
import { readFileSync, writeFileSync } from 'node:fs';
import { AnimationMixer, LoopOnce, Vector3 } from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

const [file, out] = process.argv.slice(2);
const bytes = readFileSync(file);
const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
const gltf = await new GLTFLoader().parseAsync(buffer, '');
const json = gltf.parser.json;
const joints = json.skins[0].joints;
const objects = await Promise.all(joints.map((n) => gltf.parser.getDependency('node', n)));
// the objects in the scene are the ones loaded for the scene graph: find them by their association to node indices
const byNode = new Map();
gltf.scene.traverse((o) => {
  const a = gltf.parser.associations.get(o);
  if (a && a.nodes !== undefined && !byNode.has(a.nodes)) byNode.set(a.nodes, o);
});
const bones = joints.map((n, k) => byNode.get(n) ?? objects[k]);
const mixer = new AnimationMixer(gltf.scene);
const action = mixer.clipAction(gltf.animations[0]);
action.setLoop(LoopOnce, 1);
action.clampWhenFinished = true;
action.play();
const times = gltf.animations[0].tracks[0].times;
const positions = [];
const v = new Vector3();
for (let f = 0; f < times.length; f++) {
  mixer.setTime(times[f]);
  gltf.scene.updateMatrixWorld(true);
  positions.push(bones.map((b) => b.getWorldPosition(v).toArray()));
}
let meshes = 0;
gltf.scene.traverse((o) => { if (o.isSkinnedMesh) meshes += 1; });
writeFileSync(out, JSON.stringify({
  names: joints.map((n) => json.nodes[n].name), fps: json.animations[0].extras?.fps ?? null,
  frames: times.length, positions, meshes,
}));
