// Test fixture: line 3 has a type error on purpose.
float broken_lib() {
    return vec3(1.0);
}
