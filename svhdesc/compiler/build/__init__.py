"""svhdesc/compiler/build"""
