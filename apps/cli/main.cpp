#include <cstdio>
int main() { std::puts("tetopt: under construction"); return 0; }
