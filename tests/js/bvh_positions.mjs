// World joint positions of a BVH file as three.js reads it: BVHLoader, an AnimationMixer at each frame's time.
// usage: node bvh_positions.mjs FILE.bvh OUT.json   → {names, fps, frames, positions: [frame][joint][xyz]}
import { readFileSync, writeFileSync } from 'node:fs';
import { AnimationMixer, LoopOnce, Object3D, Vector3 } from 'three';
import { BVHLoader } from 'three/addons/loaders/BVHLoader.js';

const [file, out] = process.argv.slice(2);
const result = new BVHLoader().parse(readFileSync(file, 'utf8'));
const bones = result.skeleton.bones.filter((b) => b.name !== 'ENDSITE');
const holder = new Object3D();
holder.add(result.skeleton.bones[0]);
const mixer = new AnimationMixer(holder);
const action = mixer.clipAction(result.clip);
action.setLoop(LoopOnce, 1);
action.clampWhenFinished = true; // the last frame stays the last, not the first again
action.play();
const times = result.clip.tracks[0].times;
const positions = [];
const v = new Vector3();
for (let f = 0; f < times.length; f++) {
  mixer.setTime(times[f]);
  holder.updateMatrixWorld(true);
  positions.push(bones.map((b) => b.getWorldPosition(v).toArray()));
}
const fps = times.length > 1 ? 1 / (times[1] - times[0]) : null;
writeFileSync(out, JSON.stringify({ names: bones.map((b) => b.name), fps, frames: times.length, positions }));
