#version 300 es
// The shadow map's pass: depth only (yarn.vert's strips, facing the light).
precision mediump float;

void main() {}
