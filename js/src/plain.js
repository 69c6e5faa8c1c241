// three.js and its GLTFLoader as globals (window.THREE, window.THREE_ADDONS), for the plain page: what any
// three.js viewer shows of a cdbrdf asset, without the CDBRDF_materials_curvature_brdf plugin (the fallback).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

window.THREE = THREE;
window.THREE_ADDONS = { GLTFLoader, OrbitControls };
